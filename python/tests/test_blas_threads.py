"""While yasps steps, NumPy's BLAS runs on one thread (its spinning threads
took the cores of yasps' own pool), and afterwards on as many as before;
without threadpoolctl nothing is limited."""

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import yasps
import yasps.runtime.blas as blas
from yasps import energies as E
from yasps.sim import ImplicitEuler, box_tet_mesh, newton


def blas_threads() -> set:
    """The thread counts of the BLAS libraries loaded in this process."""
    return {lib["num_threads"] for lib in threadpool_info()
            if lib["user_api"] == "blas"}


def hanging_box(step_bound):
    """A soft box hanging by its top vertices; ``step_bound`` is called at
    every Newton iteration of its steps."""
    verts, tets = box_tet_mesh(1, size=0.2)
    rest = verts[tets]
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    s = yasps.scene("blas_box")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(verts)
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(dm))
    t.addConstant("vol", rows=1).updateValue(
        np.abs(np.linalg.det(dm))[:, None] / 6)
    c = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4),
                       source=x)
    dt = 1e-2
    s.addEnergy(t.addAttribute("elastic", computed_attribute=dt * dt *
                               E.stable_neo_hookean(
                                   E.deformation_gradient(c, t["inv"]),
                                   2e3, 5e3, t["vol"])))
    s.addEnergy(v.addAttribute("inertia",
                               computed_attribute=E.inertia(x, x_hat, 0.1)))
    s.addMinimizeTarget([x])
    top = verts[:, 2] == verts[:, 2].max()
    return ImplicitEuler(s, x, x_hat, dt, fixed=top, velocity_tolerance=1e-3,
                         step_bound=step_bound), x, top


def test_blas_runs_on_one_thread_while_stepping_and_as_before_after():
    seen = []

    def bound(x, p):
        seen.append(blas_threads())
        return 1.0

    stepper, x, top = hanging_box(bound)
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == {2}
        stepper.step()
        assert seen and all(threads == {1} for threads in seen)
        assert blas_threads() == {2}
        seen.clear()
        newton(stepper.scene, x, 1e-6, bound, fixed=top)
        assert seen and all(threads == {1} for threads in seen)
        assert blas_threads() == {2}


def test_without_threadpoolctl_nothing_is_limited(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "threadpoolctl", None)
    monkeypatch.setattr(blas, "_controller", None)
    seen = []

    def bound(x, p):
        seen.append(True)
        return 1.0

    stepper, _, _ = hanging_box(bound)
    with blas.one_blas_thread():
        pass
    assert stepper.step().converged and seen
    assert blas._controller is None


def test_the_limit_is_lifted_when_a_step_raises():
    def bound(x, p):
        raise RuntimeError("stop here")

    stepper, _, _ = hanging_box(bound)
    with threadpool_limits(limits=2, user_api="blas"):
        with pytest.raises(RuntimeError, match="stop here"):
            stepper.step()
        assert blas_threads() == {2}
