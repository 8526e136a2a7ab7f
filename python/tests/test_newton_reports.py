"""A Newton solve that stops unconverged is never silent."""

from __future__ import annotations

import pytest

import yasps
from yasps.sim import (ImplicitEuler, NewtonSettings, add_elastic_tets,
                       add_free_vertices, box_tet_mesh)


def test_unconverged_newton_is_reported_everywhere(tmp_path):
    """A step stopped by its iteration cap says so: the report's
    ``converged`` and ``residual``, a NewtonNotConverged warning from
    step() (once per stepper) and from run() (once per run, with the count
    and the worst frame), the progress bar's ``unconverged`` count and
    simulate's summary line."""
    from yasps.sim import Body, NewtonNotConverged, simulate
    from yasps.contact import surface_of
    verts, tets = box_tet_mesh(1, size=0.2)
    s = yasps.scene("capped")
    soft = s.addMesh("soft")
    b = add_free_vertices(soft, verts, 1.0)
    add_elastic_tets(soft, b.x, verts * 1.3, tets, 1e4, 4e4, scale=1e-4)
    s.addMinimizeTarget([b.x])
    # One Newton iteration cannot release a box squeezed to 1/1.3 of its
    # rest size; without a cap the same step converges.
    stepper = ImplicitEuler(s, b.x, b.x_hat, dt=0.01,
                            settings=NewtonSettings(max_iterations=1))
    with pytest.warns(NewtonNotConverged, match="once per stepper"):
        report = stepper.step()
    assert not report.converged and report.residual > 1
    with pytest.warns(NewtonNotConverged,
                      match=r"2 unconverged frames \(worst: frame [12]"):
        total = stepper.run(2, progress=False)
    assert [f for f, _ in total.unconverged] == [1, 2]
    stepper.settings = NewtonSettings(max_iterations=1)
    with pytest.warns(NewtonNotConverged):
        summary = simulate(stepper, {"box": Body(b.x, surface_of(tets))}, 2,
                           tmp_path, stills=0, video=False, progress=False)
    assert "2 unconverged frames" in summary.line()
    stepper.settings = NewtonSettings(max_iterations=50)
    report = stepper.step()
    assert report.converged
    # How it converged: one residual and step size per direction, the
    # last residual below 1 and the first above (the box had to move).
    assert len(report.residuals) == len(report.step_sizes) == \
        len(report.cg_iterations) == report.iterations
    assert report.residuals[-1] == report.residual < 1 < report.residuals[0]
    assert all(0.0 < a <= 1.0 for a in report.step_sizes)
