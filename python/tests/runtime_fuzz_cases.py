"""Malformed inputs for the runtime extension's entry points, one case per
seed (test_runtime_fuzz.py runs them in a child process, which a crash
cannot take the test run down with).

Each case builds arguments of the right Python types (NumPy arrays of the
dtypes the bindings take) with values a caller could get wrong: sizes that
disagree, indices out of range or negative, NaN and infinite entries,
zero, negative and huge tolerances, distances and thread counts, and the
result of one call passed with the arguments of another (candidates of
another mesh). A case passes when every call returns or raises a
YaspsError; a crash, a sanitizer report or any other exception is a
finding. TypeError is allowed where nanobind refuses an argument's type or
dimensions before the extension's code runs.

    python3 runtime_fuzz_cases.py ENTRY FIRST_SEED COUNT [SEED ...]

prints each seed before running it (so that the last seed printed names a
crash) and exits 2 on an unexpected exception.
"""

from __future__ import annotations

import sys
from typing import Callable, Dict, List

import numpy as np

import yasps
from yasps._native import runtime_module

rt = runtime_module()

ODD_REALS = [0.0, -1.0, 1e-300, 1e300, -1e300, float("nan"), float("inf"),
             -float("inf"), 1e-3, 0.1, 1.0]


def odd_real(rng: np.random.Generator) -> float:
    """A scalar a caller might pass: mostly plain, often extreme."""
    if rng.random() < 0.4:
        return float(rng.uniform(1e-4, 1.0))
    return float(ODD_REALS[rng.integers(len(ODD_REALS))])


def odd_index(rng: np.random.Generator, n: int) -> int:
    """An index into n things: in range, at its ends, or outside them."""
    choices = [-(2 ** 31), -1, 0, n - 1, n, n + 1, 2 ** 31 - 1]
    if n > 0 and rng.random() < 0.6:
        return int(rng.integers(n))
    return int(choices[rng.integers(len(choices))])


def odd_count(rng: np.random.Generator, n: int) -> int:
    """A count meant to be n: mostly n, else one off or zero."""
    return int(n if rng.random() < 0.7 else
               max(0, n + int(rng.choice([-1, 1, -n]))))


def odd_threads(rng: np.random.Generator) -> int:
    return int(rng.choice([0, 1, 2, 3, 64, 1024, 1025, 100000]))


def positions(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n', 3) positions, n' mostly n; some entries NaN, infinite or huge."""
    v = rng.uniform(-1.0, 1.0, size=(odd_count(rng, n), 3))
    if v.size and rng.random() < 0.3:
        v.flat[rng.integers(v.size)] = odd_real(rng)
    return v


def values(rng: np.random.Generator, size: int) -> np.ndarray:
    """``size`` f64 values (sometimes one off), some of them odd."""
    out = rng.normal(size=odd_count(rng, size))
    if out.size and rng.random() < 0.3:
        out.flat[rng.integers(out.size)] = odd_real(rng)
    return out


# ----------------------------------------------------------------- contact


def contact_mesh(rng: np.random.Generator):
    """A small surface (tets' faces, a loose edge, a loose point), its
    indices sometimes out of range; (mesh or None, vertex count)."""
    n = int(rng.integers(0, 9))
    rest = rng.uniform(-1.0, 1.0, size=(n, 3))
    faces = np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]],
                     dtype=np.int32)[: int(rng.integers(0, 5))]
    sides = {tuple(sorted((f[k], f[(k + 1) % 3]))) for f in faces
             for k in range(3)}
    edges = np.array(sorted(sides) + [(4, 5)], dtype=np.int32).reshape(-1, 2)
    for array in (faces, edges):
        if array.size and rng.random() < 0.25:
            array.flat[rng.integers(array.size)] = odd_index(rng, n)
    if rest.size and rng.random() < 0.1:
        rest.flat[rng.integers(rest.size)] = odd_real(rng)
    try:
        return rt.ContactMesh(rest, edges, faces), n
    except yasps.YaspsError:
        return None, n


def contact_case(rng: np.random.Generator) -> None:
    mesh, n = contact_mesh(rng)
    other, m = contact_mesh(rng)
    if mesh is None:
        return
    threads = odd_threads(rng) if rng.random() < 0.2 else 0
    candidates = rt.contact_candidates(
        mesh, positions(rng, n), positions(rng, n),
        odd_real(rng) if rng.random() < 0.3 else 0.01, threads)
    # Candidates of another mesh, or of this one.
    if other is not None and rng.random() < 0.5:
        try:
            candidates = rt.contact_candidates(other, positions(rng, m),
                                               positions(rng, m), 1.0)
        except yasps.YaspsError:
            pass
    len(candidates)
    for pairs in (candidates.face_vertex, candidates.edge_edge,
                  candidates.vertex_vertex, candidates.edge_vertex):
        assert pairs.ndim == 2 and pairs.shape[1] == 2
    which = rng.integers(2)
    try:
        if which == 0:
            rt.contact_collision_set(mesh, candidates, positions(rng, n),
                                     odd_real(rng), threads)
        else:
            rt.contact_step_bound(mesh, candidates, positions(rng, n),
                                  positions(rng, n), odd_real(rng), threads)
    except yasps.YaspsError:
        pass


# ------------------------------------------------------------------ system


def dof_map(rng: np.random.Generator, size: int) -> np.ndarray:
    """A (count, n) DoF map of blocks' first DoFs and -1 (no DoF), some
    entries out of range."""
    count, n = int(rng.integers(0, 5)), int(rng.choice([1, 3, 6]))
    out = rng.integers(-1, max(size, 1), size=(count, n)).astype(np.int64)
    if out.size and rng.random() < 0.3:
        out.flat[rng.integers(out.size)] = odd_index(rng, size)
    return out


def block_offsets(rng: np.random.Generator) -> np.ndarray:
    """Offsets of 0-4 blocks of 3 DoFs, sometimes not increasing or not
    starting at 0 (never past 64: the system allocates what they say)."""
    blocks = int(rng.integers(0, 5))
    offsets = np.arange(blocks + 1, dtype=np.int64) * 3
    if rng.random() < 0.3:
        offsets[rng.integers(offsets.size)] = rng.integers(-4, 64)
    return offsets


def system_case(rng: np.random.Generator) -> None:
    offsets = block_offsets(rng)
    size = int(offsets[-1]) if offsets.size and offsets[-1] >= 0 else 0
    maps = [dof_map(rng, size) for _ in range(int(rng.integers(0, 3)))]
    try:
        system = rt.GlobalSystem(offsets, maps)
    except yasps.YaspsError:
        return
    threads = odd_threads(rng) if rng.random() < 0.2 else 0
    if rng.random() < 0.3:
        try:
            system.set_dynamic([dof_map(rng, size)])
            maps = maps + [np.zeros((0, 1), np.int64)]
        except yasps.YaspsError:
            pass
    for _ in range(int(rng.integers(1, 4))):
        energy = odd_index(rng, len(maps))
        count, n = maps[energy].shape if 0 <= energy < len(maps) else (1, 3)
        step = rng.integers(4)
        try:
            if step == 0:
                system.add(energy, values(rng, count * n),
                           values(rng, count * n * n), threads)
            elif step == 1:
                instances = np.array([odd_index(rng, count)
                                      for _ in range(int(rng.integers(0, 3)))],
                                     dtype=np.int64)
                system.add_to_instances(energy, instances,
                                        values(rng, instances.size * n * n))
            elif step == 2:
                m = int(rng.integers(0, 4))
                system.add_factored(energy, values(rng, count * n),
                                    values(rng, count * m * n),
                                    values(rng, count * m * m), m, threads)
            else:
                slot_factored(rng, system, energy, count, n, threads)
        except yasps.YaspsError:
            pass
    system.finish_assembly()
    fixed = (rng.random(odd_count(rng, size)) < 0.3).astype(np.uint8) \
        if rng.random() < 0.5 else None
    out = np.zeros(odd_count(rng, size))
    preconditioner = rt.PcgPreconditioner.multilevel if rng.random() < 0.5 \
        else rt.PcgPreconditioner.block_jacobi
    try:
        system.solve(out, odd_real(rng), int(rng.choice([-1, 0, 3, 50])),
                     threads, fixed, rt.PcgStopping.residual, preconditioner)
    except yasps.YaspsError:
        pass
    try:
        system.multiply(values(rng, size), np.zeros(odd_count(rng, size)),
                        threads)
    except yasps.YaspsError:
        pass


def slot_factored(rng: np.random.Generator, system, energy: int, count: int,
                  n: int, threads: int) -> None:
    """add_slot_factored with Jacobian tables, slots and sources of which
    some index past what they index."""
    m = int(rng.integers(1, 4))
    tables = [rng.normal(size=(int(rng.integers(0, 3)), m, 3))
              for _ in range(int(rng.integers(0, 3)))]
    slots = np.array([[odd_index(rng, m), odd_index(rng, m + 1),
                       odd_index(rng, n)]
                      for _ in range(int(rng.integers(0, 3)))],
                     dtype=np.int64).reshape(-1, 3)
    sources = np.array([[odd_index(rng, len(tables)), odd_index(rng, 2)]
                        for _ in range(count * len(slots))],
                       dtype=np.int64).reshape(count, len(slots), 2)
    system.add_slot_factored(energy, values(rng, count * m),
                             values(rng, count * m * m), m, tables, slots,
                             sources, threads)


# ------------------------------------------------------------- compression


def compression_case(rng: np.random.Generator) -> None:
    count, n = int(rng.integers(0, 4)), int(rng.choice([1, 3, 6]))
    dofs = rng.integers(-1, 12, size=(count, n)).astype(np.int64)
    if dofs.size and rng.random() < 0.3:
        dofs.flat[rng.integers(dofs.size)] = odd_index(rng, 12)
    rt.compressed_sizes(dofs)
    groups = rt.compress_local_hessians(dofs, values(rng, count * n * n))
    out = np.zeros(odd_count(rng, count * n * n))
    for k, instances, matrices in groups:
        if rng.random() < 0.3 and instances.size:
            instances = instances.copy()
            instances[rng.integers(instances.size)] = odd_index(rng, count)
        if rng.random() < 0.2:
            k = odd_index(rng, k + 1)
        rt.expand_local_hessians(dofs, int(k), instances,
                                 np.ascontiguousarray(matrices), out)


ENTRIES: Dict[str, Callable[[np.random.Generator], None]] = {
    "contact": contact_case,
    "system": system_case,
    "compression": compression_case,
}


def run(entry: str, seeds: List[int]) -> int:
    """Runs the cases; 0 if each returned or raised what it may."""
    case = ENTRIES[entry]
    for seed in seeds:
        print(seed, flush=True)
        try:
            case(np.random.default_rng(seed))
        except (yasps.YaspsError, TypeError):
            pass
        except Exception as error:  # noqa: BLE001 - any other is a finding
            print(f"seed {seed}: {type(error).__name__}: {error}",
                  flush=True)
            return 2
    return 0


if __name__ == "__main__":
    name, first, count, *more = sys.argv[1:]
    sys.exit(run(name, [int(s) for s in more] +
                 list(range(int(first), int(first) + int(count)))))
