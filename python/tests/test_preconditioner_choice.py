"""``config.preconditioner = "auto"`` (yasps.solve.preconditioner_choice):
the choice follows the cost model from iteration counts alone, its trials
stay within their budget and are redone when they miss it, it repeats run
for run, and a checkpoint carries it so that a resumed run continues bit
for bit."""

import math

import numpy as np
import pytest

import yasps
from yasps.sim import (ImplicitEuler, NewtonSettings, add_cloth,
                       add_free_vertices, cloth_grid, lumped_masses)
from yasps.solve import preconditioner_choice as pc
from yasps.solve.preconditioner_choice import (BLOCK_JACOBI, MULTILEVEL,
                                               PreconditionerChoice,
                                               solve_cost, trial_budget)


@pytest.fixture(autouse=True)
def restore_preconditioner():
    kept = yasps.config.preconditioner
    yield
    yasps.config.preconditioner = kept


def stiff_cloth(cells: int, name: str):
    """A 5 m, 1 kg cloth with the paper's cloths-on-bunny stiffness (its
    stretch against its mass over dt^2 is what makes block-Jacobi slow),
    pinned at its border, predicted a smooth in-plane displacement away
    from rest: (scene, fixed, free vertices)."""
    verts, faces = cloth_grid(cells, size=5.0)
    s = yasps.scene(name)
    mesh = s.addMesh("cloth")
    free = add_free_vertices(mesh, verts,
                             lumped_masses(verts, faces, 1.0 / 25.0))
    add_cloth(mesh, free.x, verts, faces, stretch=671.0, shear=201.0,
              bending=0.055, scale=1e-4)
    shift = np.zeros_like(verts)
    shift[:, 0] = 1e-2 * np.sin(np.pi * verts[:, 0] / 5.0) * \
        np.cos(np.pi * verts[:, 1] / 5.0)
    free.x_hat.updateValue(verts + shift)
    s.addMinimizeTarget([free.x])
    border = np.abs(verts[:, :2]).max(axis=1) > 2.5 - 1e-9
    return s, [np.repeat(border[:, None], 3, axis=1)[:, :, None]], free


def solve(scene, fixed, preconditioner: str):
    yasps.config.preconditioner = preconditioner
    (dx,) = scene.minimizeEnergy(tolerance=1e-4, stopping="preconditioned",
                                 fixed=fixed)
    return dx, dict(scene.lastSolve)


@pytest.mark.parametrize("cells, cheaper", [(16, BLOCK_JACOBI),
                                            (80, MULTILEVEL)])
def test_auto_takes_the_cheaper_by_the_model(cells, cheaper):
    """On a coarse cloth block-Jacobi's solves cost less by the model, on a
    fine one the multilevel's (the one the model names is asserted too, so
    that both outcomes are covered); auto ends on it and solves the same
    system."""
    s, fixed, _ = stiff_cloth(cells, f"cloth_{cells}")
    counts = {p: solve(s, fixed, p)[1]["iterations"]
              for p in (BLOCK_JACOBI, MULTILEVEL)}
    assert min(counts, key=lambda p: solve_cost(p, counts[p])) == cheaper
    reference, _ = solve(s, fixed, BLOCK_JACOBI)
    for _ in range(3):
        dx, info = solve(s, fixed, "auto")
    assert info["preconditioner"] == cheaper and info["converged"]
    assert info["iterations"] == counts[cheaper]
    scale = np.abs(reference).max()
    np.testing.assert_allclose(dx, reference, atol=1e-2 * scale)


def test_trials_keep_to_their_budget_and_back_off():
    """Where block-Jacobi stays the cheaper, the multilevel is tried at
    solves 2, 4, 8, 16 (the period doubling), each stopped at the
    iterations that would have cost as much as block-Jacobi's solve, and
    redone: the solve kept is block-Jacobi's, its iterations unchanged."""
    s, fixed, _ = stiff_cloth(24, "cloth_trials")
    _, jacobi = solve(s, fixed, BLOCK_JACOBI)
    budget = math.floor((pc.MARGIN * solve_cost(BLOCK_JACOBI,
                                                jacobi["iterations"])
                         - pc.SETUP[MULTILEVEL]) / pc.ITERATION[MULTILEVEL])
    assert budget >= pc.MIN_TRIAL_ITERATIONS
    trials = []
    for k in range(1, 17):
        _, info = solve(s, fixed, "auto")
        assert info["preconditioner"] == BLOCK_JACOBI
        assert info["iterations"] == jacobi["iterations"]
        if info["trialIterations"]:
            assert info["trialIterations"] == budget
            trials.append(k)
    assert trials == [2, 4, 8, 16]


def test_auto_repeats_run_for_run():
    """Two fresh scenes make the same choices and the same directions, bit
    for bit: nothing depends on a clock."""
    runs = []
    for name in ("cloth_once", "cloth_twice"):
        s, fixed, free = stiff_cloth(60, name)
        seen = []
        for k in range(6):
            dx, info = solve(s, fixed, "auto")
            seen.append((info["preconditioner"], info["iterations"],
                         info["trialIterations"], dx.tobytes()))
            # Move along (half a step) so that the systems change.
            free.x.updateValue(free.x.value - 0.5 * dx)
        runs.append(seen)
    assert runs[0] == runs[1]
    assert {p for p, *_ in runs[0]} == {BLOCK_JACOBI, MULTILEVEL}


def test_a_checkpoint_carries_the_choice(tmp_path):
    """A run that switched to the multilevel preconditioner, saved and
    resumed in a fresh stepper, continues bit for bit; resumed without the
    choice it does not (the state matters, and the checkpoint kept it)."""
    path = tmp_path / "state.npz"

    def stepper(name):
        s, fixed, free = stiff_cloth(80, name)
        return ImplicitEuler(s, [free.x], [free.x_hat], dt=0.01,
                             gravity=[(0.0, 0.0, -9.81)], fixed=fixed,
                             settings=NewtonSettings(
                                 cg_tolerance=1e-4,
                                 cg_stopping="preconditioned"))

    yasps.config.preconditioner = "auto"
    run = stepper("cloth_saved")
    for _ in range(6):
        run.step()
        saved = pc.state(run.scene)
        if pc.PreconditionerChoice.from_array(saved).current == MULTILEVEL:
            break
    assert pc.PreconditionerChoice.from_array(saved).current == MULTILEVEL
    run.save(path)
    for _ in range(3):
        run.step()
    want = run.targets[0].value.copy()

    resumed = stepper("cloth_resumed")
    resumed.restore(path)
    np.testing.assert_array_equal(pc.state(resumed.scene), saved)
    for _ in range(3):
        resumed.step()
    np.testing.assert_array_equal(resumed.targets[0].value, want)

    fresh = stepper("cloth_fresh")
    fresh.restore(path)
    pc.restore(fresh.scene, None)
    for _ in range(3):
        fresh.step()
    assert not np.array_equal(fresh.targets[0].value, want)


def feed(choice: PreconditionerChoice, needs: dict, solves: int,
         cap: int = 1000):
    """Runs ``solves`` solves through the choice, where preconditioner p
    needs ``needs[p]`` iterations; returns the model cost of each solve
    (trials and redos included) and the preconditioner kept."""
    costs, kept = [], []
    for _ in range(solves):
        cost = 0.0
        while True:
            attempt = choice.next_attempt(cap)
            assert attempt.max_iterations <= cap
            done = min(needs[attempt.preconditioner], attempt.max_iterations)
            stop = "converged" if needs[attempt.preconditioner] <= \
                attempt.max_iterations else "max_iterations"
            cost += solve_cost(attempt.preconditioner, done)
            if not choice.record(attempt, done, stop,
                                 done / needs[attempt.preconditioner]):
                break
        costs.append(cost)
        kept.append(attempt.preconditioner)
    return costs, kept


def test_the_choice_follows_a_change_of_regime():
    """A regime where the multilevel preconditioner pays (180 iterations
    against 16, as the paper-scale cloths-on-bunny's while its cloth
    falls), then one where block-Jacobi does (40 against 45). The choice
    switches within a few solves of each change (the multilevel's solves
    growing costlier calls a trial at once, whatever the period) and costs
    at most 10% over the oracle that knows the cheaper one at every
    solve."""
    choice = PreconditionerChoice()
    falling = {BLOCK_JACOBI: 180, MULTILEVEL: 16}
    contact = {BLOCK_JACOBI: 40, MULTILEVEL: 45}
    costs, kept = feed(choice, falling, 100)
    more, kept_contact = feed(choice, contact, 100)
    assert kept[:1] == [BLOCK_JACOBI] and set(kept[2:]) == {MULTILEVEL}
    switch = kept_contact.index(BLOCK_JACOBI)
    assert switch <= 1
    assert set(kept_contact[switch:]) == {BLOCK_JACOBI}
    oracle = 100 * min(solve_cost(p, n) for p, n in falling.items()) + \
        100 * min(solve_cost(p, n) for p, n in contact.items())
    assert sum(costs) + sum(more) <= 1.1 * oracle


def test_no_trial_where_the_multilevel_cannot_pay():
    """Block-Jacobi at 10 iterations leaves the multilevel's budget fewer
    iterations than a trial needs: it is never tried."""
    choice = PreconditionerChoice()
    for _ in range(50):
        attempt = choice.next_attempt(1000)
        assert attempt == pc.Attempt(BLOCK_JACOBI, 1000, False)
        assert not choice.record(attempt, 10, "converged")


def test_a_solve_stopped_at_its_cap_calls_a_trial():
    """A block-Jacobi solve that hit the iteration cap makes the next solve
    a trial, whatever the period."""
    choice = PreconditionerChoice(period=64)
    attempt = choice.next_attempt(300)
    choice.record(attempt, 300, "max_iterations")
    trial = choice.next_attempt(300)
    assert trial.trial and trial.preconditioner == MULTILEVEL
    assert trial.max_iterations == math.floor(
        (pc.MARGIN * solve_cost(BLOCK_JACOBI, 300) - pc.SETUP[MULTILEVEL]) /
        pc.ITERATION[MULTILEVEL])


def test_the_state_survives_its_array():
    choice = PreconditionerChoice(MULTILEVEL, {MULTILEVEL: 99.0}, 16, 3, 80.0)
    assert PreconditionerChoice.from_array(choice.as_array()) == choice
    assert PreconditionerChoice.from_array(
        PreconditionerChoice().as_array()) == PreconditionerChoice()


def test_a_trial_far_from_converging_waits_the_longest():
    """A trial stopped at a tenth of the way to its tolerance (in orders of
    magnitude) sets the period to its longest at once when its redo is no
    dearer than before; one nearly there doubles it; a rise of the
    current's costs above what it won at calls a trial before the period is
    out."""
    reached = type("Report", (), {"relative_residual": 10 ** -0.4,
                                  "preconditioned_residual": float("nan"),
                                  "energy_error": float("nan")})()
    assert pc.progress(reached, 1e-4, "residual") == pytest.approx(0.1)
    assert pc.progress(reached, 1e-4, "preconditioned") == 0.0
    choices = []
    for progress, period in ((0.1, pc.MAX_PERIOD), (0.9, 2)):
        choice = PreconditionerChoice()
        choices.append(choice)
        choice.record(choice.next_attempt(1000), 200, "converged")
        trial = choice.next_attempt(1000)
        assert trial.trial
        assert choice.record(trial, trial.max_iterations, "max_iterations",
                             progress)
        redo = choice.next_attempt(1000)
        assert redo == pc.Attempt(BLOCK_JACOBI, 1000, False)
        assert not choice.record(redo, 200, "converged")
        assert choice.period == period and choice.won_at == 205.0
    choice = choices[0]
    choice.record(choice.next_attempt(1000), 200, "converged")
    assert not choice.next_attempt(1000).trial
    choice.record(choice.next_attempt(1000), 400, "converged")
    assert choice.next_attempt(1000).trial


def failed_trial(choice: PreconditionerChoice, progress: float,
                 stop: str = "max_iterations") -> pc.Attempt:
    """Runs block-Jacobi solves of 200 iterations until a trial comes, and
    records that trial as stopped by ``stop`` having come ``progress`` of
    the way; returns its redo."""
    while True:
        attempt = choice.next_attempt(1000)
        if attempt.trial:
            break
        choice.record(attempt, 200, "converged")
    assert choice.record(attempt, attempt.max_iterations, stop, progress)
    return choice.next_attempt(1000)


def test_the_redo_of_the_same_system_judges_a_trial():
    """A trial stopped at its cap halfway to its tolerance would have cost
    about twice its cap: against a redo that took 200 iterations it loses
    (the period doubles); against a redo that took 600, the system being
    harder than the solves its budget came from, it wins and the next
    solve is the multilevel's."""
    for redo_iterations, switched in ((200, False), (600, True)):
        choice = PreconditionerChoice()
        redo = failed_trial(choice, 0.5)
        budget = trial_budget(MULTILEVEL, 205.0)
        estimate = solve_cost(MULTILEVEL, budget / 0.5)
        assert (estimate <= pc.MARGIN * solve_cost(
            BLOCK_JACOBI, redo_iterations)) == switched
        assert not choice.record(redo, redo_iterations, "converged")
        if switched:
            assert choice.current == MULTILEVEL
            assert choice.costs[MULTILEVEL] == estimate
            assert choice.next_attempt(1000) == \
                pc.Attempt(MULTILEVEL, 1000, False)
        else:
            assert choice.current == BLOCK_JACOBI and choice.period == 2


def test_a_breakdown_is_no_verdict():
    """A trial or its redo that broke down (an indefinite system) leaves the
    period as it was and makes the next solve a trial again."""
    for trial_stop, redo_stop in (("breakdown", "breakdown"),
                                  ("max_iterations", "breakdown"),
                                  ("breakdown", "converged")):
        choice = PreconditionerChoice()
        redo = failed_trial(choice, 0.0, trial_stop)
        assert not redo.trial
        choice.record(redo, 3, redo_stop)
        assert choice.period == pc.FIRST_PERIOD
        assert choice.current == BLOCK_JACOBI
        assert choice.next_attempt(1000).trial


def test_the_redo_of_a_trial_is_never_a_trial():
    """After a trial that did not converge, the next attempt is the redo
    with the current preconditioner, even where the current's costs have
    risen past what it last won at (which calls a trial otherwise)."""
    choice = PreconditionerChoice(BLOCK_JACOBI, {BLOCK_JACOBI: 300.0}, 64, 0,
                                  100.0)
    trial = choice.next_attempt(1000)
    assert trial.trial
    assert choice.record(trial, trial.max_iterations, "max_iterations", 0.9)
    assert choice.next_attempt(1000) == pc.Attempt(BLOCK_JACOBI, 1000, False)


ON_THE_GPU = """
    import sys
    import yasps
    sys.path.insert(0, %r)
    from test_preconditioner_choice import stiff_cloth, solve
    yasps.config.gpu_derivatives = False
    for backend in ("cpu", "gpu"):
        yasps.config.backend = backend
        s, fixed, _ = stiff_cloth(40, "cloth_" + backend)
        seen = [solve(s, fixed, "auto")[1] for _ in range(2)]
        print(backend, *[(i["backend"], i["preconditioner"],
                          i["trialIterations"] > 0) for i in seen])
"""


def test_auto_is_block_jacobi_on_the_gpu_backend():
    """The cost model is the CPU's: on the GPU backend (its kernels run by
    the stand-in driver) "auto" solves with block-Jacobi and tries nothing,
    where the CPU tries the multilevel preconditioner at its second solve."""
    from pathlib import Path
    from test_gpu_runtime import FAKE_DRIVER, HAS_PTXAS, run_python
    if not FAKE_DRIVER.exists() or not HAS_PTXAS:
        pytest.skip("needs the stand-in driver and the CUDA toolkit")
    out = run_python(ON_THE_GPU % str(Path(__file__).resolve().parent),
                     YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    # The CPU's trial at the second solve converges within its budget on
    # this cloth, and is the solve kept.
    cpu = "cpu ('cpu', 'block-jacobi', False) ('cpu', 'multilevel', False)"
    gpu = "gpu ('gpu', 'block-jacobi', False) ('gpu', 'block-jacobi', False)"
    assert out.strip().splitlines()[-2:] == [cpu, gpu], out
