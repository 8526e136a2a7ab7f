"""Old spellings of renamed public names (docs/python.md, "Names and old
spellings"): each still does what its new name does, and warns once per
process with YaspsDeprecationWarning, naming the new one."""

import dataclasses
import warnings

import ipctk
import numpy as np
import pytest

import yasps
import yasps.deprecation
from yasps.contact import Contact, surface_of
from yasps.sim import (ImplicitEuler, NewtonReport, NewtonSettings,
                       add_elastic_tets, add_free_vertices, box_tet_mesh,
                       newton)

VERTS, TETS = box_tet_mesh(1, size=0.2)


@pytest.fixture(autouse=True)
def nothing_warned_yet(monkeypatch):
    """Each test starts as a fresh process would: no old name warned."""
    monkeypatch.setattr(yasps.deprecation, "_warned", set())


def deprecations(fn):
    """``fn()``'s result and the messages of the deprecation warnings it
    raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn()
    return result, [str(w.message) for w in caught
                    if issubclass(w.category, yasps.YaspsDeprecationWarning)]


def assert_warns_once(fn, new: str):
    """``fn()`` warns once naming ``new``; called again, not at all.
    Returns the first call's result."""
    result, first = deprecations(fn)
    assert len(first) == 1 and new in first[0], first
    _, second = deprecations(fn)
    assert second == []
    return result


def box_scene(name: str, lift: float = 0.0):
    """A soft box squeezed to 1/1.3 of its rest size, ``lift`` above the
    ground: (scene, its free vertices)."""
    s = yasps.scene(name)
    soft = s.addMesh("soft")
    b = add_free_vertices(soft, VERTS + [0.0, 0.0, lift], 1.0)
    add_elastic_tets(soft, b.x, VERTS * 1.3, TETS, 1e4, 4e4, scale=1e-4)
    s.addMinimizeTarget([b.x])
    return s, b


def test_the_warning_is_a_future_warning_that_python_shows():
    assert issubclass(yasps.YaspsDeprecationWarning, FutureWarning)


def test_contact_methods_keep_their_camel_case_spellings():
    s, b = box_scene("old_contact", lift=0.02)
    contact = Contact(s, b.x.owner, faces=surface_of(TETS), dhat=1e-2,
                      average_mass=1.0, halfspaces=[((0, 0, 0), (0, 0, 1))])
    contact.update()
    down = [np.tile([0.0, 0.0, -0.05], (len(VERTS), 1))]
    calls = [("stepBound", "step_bound", (down,)),
             ("stepBoundAndLength", "step_bound_and_length", (down,)),
             ("minDistance", "min_distance", ()),
             ("hasIntersections", "has_intersections", ()),
             ("adaptStiffness", "adapt_stiffness", ()),
             ("forgetCandidates", "forget_candidates", ())]
    for old, new, args in calls:
        want = getattr(contact, new)(*args)
        got = assert_warns_once(lambda: getattr(contact, old)(*args),
                                f"Contact.{new}")
        assert got == want, old
    # The bound is CCD's: the box stops short of the ground.
    assert 0.0 < contact.step_bound(down) < 1.0
    world = contact.world()
    checker = ipctk.CollisionMesh(world, contact.mesh.edges,
                                  contact.mesh.faces)
    assert not ipctk.has_intersections(checker, world)


def test_newton_report_fields_keep_their_camel_case_spellings():
    report = NewtonReport()
    report.cg_iterations.append(3)
    assert assert_warns_once(lambda: report.cgIterations,
                             "NewtonReport.cg_iterations") == [3]
    _, messages = deprecations(lambda: setattr(report, "frictionLags", 2))
    assert len(messages) == 1 and report.friction_lags == 2
    for old in ("stepEnergies", "stepBounds", "stepSizes",
                "inexactDirections", "projectionRetries", "tightenedSolves",
                "prescribedLag"):
        assert deprecations(lambda: getattr(report, old))[0] is getattr(
            report, {"stepEnergies": "step_energies",
                     "stepBounds": "step_bounds", "stepSizes": "step_sizes",
                     "inexactDirections": "inexact_directions",
                     "projectionRetries": "projection_retries",
                     "tightenedSolves": "tightened_solves",
                     "prescribedLag": "prescribed_lag"}[old])


def test_old_stepper_keywords_step_as_the_settings_do():
    """x=, x_hat= and the settings' fields as keywords make the stepper
    that targets=, predicted= and NewtonSettings make: the same settings
    and, bit for bit, the same step."""
    s_old, b_old = box_scene("old_keywords")
    s_new, b_new = box_scene("new_keywords")
    settings = NewtonSettings(max_iterations=7, cg_tolerance=1e-6,
                              projection="full")

    def old():
        return ImplicitEuler(s_old, x=b_old.x, x_hat=b_old.x_hat, dt=0.01,
                             max_iterations=7, cg_tolerance=1e-6,
                             projection="full")

    stepper, messages = deprecations(old)
    assert len(messages) == 5, messages
    assert any("ImplicitEuler(targets=)" in m for m in messages)
    assert any("NewtonSettings(cg_tolerance=...)" in m for m in messages)
    assert deprecations(old)[1] == []
    new = ImplicitEuler(s_new, targets=b_new.x, predicted=b_new.x_hat,
                        dt=0.01, settings=settings)
    assert stepper.settings == new.settings == settings
    stepper.step()
    new.step()
    np.testing.assert_array_equal(b_old.x.value, b_new.x.value)
    # The stepper's attributes of the settings' names read and replace them.
    assert assert_warns_once(lambda: stepper.cg_tolerance,
                             "ImplicitEuler.settings.cg_tolerance") == 1e-6
    deprecations(lambda: setattr(stepper, "max_iterations", 3))
    assert stepper.settings == dataclasses.replace(settings, max_iterations=3)
    assert assert_warns_once(lambda: stepper.velocity,
                             "velocities[0]") is stepper.velocities[0]


def test_old_newton_keywords_solve_as_the_settings_do():
    s_old, b_old = box_scene("old_newton")
    s_new, b_new = box_scene("new_newton")
    old, messages = deprecations(lambda: newton(
        s_old, x=b_old.x, tolerance=1e-8, cg_forcing=False, cg_tolerance=1e-8))
    assert len(messages) == 3, messages
    new = newton(s_new, b_new.x, 1e-8, settings=NewtonSettings(
        cg_forcing=False, cg_tolerance=1e-8))
    assert old.converged and new.converged
    assert old.cg_iterations == new.cg_iterations
    np.testing.assert_array_equal(b_old.x.value, b_new.x.value)


def test_bad_spellings_and_settings_are_refused():
    s, b = box_scene("refused")
    with pytest.raises(yasps.errors.ArgumentTypeError, match="targets= only"):
        deprecations(lambda: ImplicitEuler(s, b.x, b.x_hat, 0.01, x=b.x))
    with pytest.raises(TypeError, match="unexpected keyword argument 'cg_tol'"):
        ImplicitEuler(s, b.x, b.x_hat, 0.01, cg_tol=1e-3)
    with pytest.raises(yasps.errors.ArgumentTypeError,
                       match="settings must be a NewtonSettings"):
        newton(s, b.x, 1e-6, settings={"cg_tolerance": 1e-3})
    with pytest.raises(yasps.ArgumentError, match="projection must be one"):
        NewtonSettings(projection="sometimes")
    with pytest.raises(yasps.ArgumentError, match="cg_stopping must be one"):
        NewtonSettings(cg_stopping="never")
    with pytest.raises(yasps.errors.ArgumentTypeError, match="whole number"):
        NewtonSettings(max_iterations=1.5)
    with pytest.raises(yasps.ArgumentError, match="finite number >= 0"):
        NewtonSettings(cg_tolerance=float("nan"))
    # NumPy's numbers are the numbers they stand for.
    assert NewtonSettings(max_iterations=np.int64(4)).max_iterations == 4
    with pytest.raises(dataclasses.FrozenInstanceError):
        NewtonSettings().cg_tolerance = 1.0  # type: ignore[misc]
