"""The energies the derivative benchmarks compare, defined once.

Each :class:`Case` holds, for one energy:

- ``sample``: its N random, non-degenerate instances, as flat per-instance
  arrays (N, k): the differentiated parameters first (point coordinates
  vertex after vertex, matrices column-major: yasps' parameter order), then
  per-instance constants (row-major);
- ``scene``: the yasps scene of these instances, built with
  ``yasps.energies``;
- ``formula``: the same energy written independently of yasps, once, over a
  small set of operations (:class:`ArrayOps` for NumPy and JAX,
  :class:`TorchOps`, :class:`SympyOps`), so that JAX, PyTorch and SymPy
  differentiate the same expression.

``bench/derivatives.py`` times yasps' kernels against JAX and PyTorch on
these cases, ``bench/sympy_compare.py`` against SymPy's generated C.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial
from typing import Any, Callable, List, Sequence, Tuple

import numpy as np

import yasps
from yasps import energies as E
from yasps.compiler.cpu import compile_cpu
from yasps.compiler.pipelines import DIFFERENTIATION_PIPELINE
from yasps.ir import emit_scene
from yasps.runtime.inputs import host_input
from yasps.compiler.params import ArgumentKind
from yasps.runtime.cpu import launch

MU, LAM = 1.0, 10.0             # stable Neo-Hookean
MASS = 2.0                      # inertia and gravity
GRAVITY = (0.0, -9.81, 0.0)
SPRING_REST, SPRING_K = 1.0, 3.0
BW_AREA, BW_STRETCH, BW_SHEAR = 0.5, 30.0, 10.0
BEND_REST, BEND_K = 0.7, 2.0
KAPPA = 1e3                     # IPC barrier stiffness
ABD_K = 3.0
PENDULUM_G, PENDULUM_TARGET = 9.81, (0.3, -1.0)


# --- operations for the independent formulas ---------------------------------

class ArrayOps:
    """Formula operations on one instance for NumPy or ``jax.numpy``
    (``xp``): vectors are 1-D arrays."""

    def __init__(self, xp: Any) -> None:
        self.xp = xp

    def points(self, flat, k: int) -> list:
        """The k 3-vectors stored one after another in ``flat``."""
        return [flat[3 * i:3 * i + 3] for i in range(k)]

    def matrix(self, flat, rows: int, cols: int):
        """A matrix stored row-major in ``flat``."""
        return flat.reshape(rows, cols)

    def columns(self, vectors: list):
        return self.xp.stack(vectors, axis=1)

    def vector(self, entries: list):
        return self.xp.stack(entries)

    def constant(self, values):
        return self.xp.asarray(values, dtype=self.xp.float64)

    def eye(self, n: int):
        return self.xp.eye(n)

    def dot(self, a, b):
        return self.xp.dot(a, b)

    def cross(self, a, b):
        return self.xp.cross(a, b)

    def sqnorm(self, a):
        """Squared Euclidean (vectors) or Frobenius (matrices) norm."""
        return self.xp.sum(a * a)

    def norm(self, a):
        return self.xp.linalg.norm(a)

    def det(self, a):
        return self.xp.linalg.det(a)

    def log(self, a):
        return self.xp.log(a)

    def sin(self, a):
        return self.xp.sin(a)

    def cos(self, a):
        return self.xp.cos(a)

    def where_active(self, condition, value):
        """``value`` where ``condition`` holds, else 0."""
        return self.xp.where(condition, value, 0.0)


class TorchOps(ArrayOps):
    """Formula operations for PyTorch (under ``torch.func``)."""

    def __init__(self) -> None:
        import torch
        super().__init__(torch)

    def columns(self, vectors: list):
        return self.xp.stack(vectors, dim=1)

    def eye(self, n: int):
        return self.xp.eye(n, dtype=self.xp.float64)

    def constant(self, values):
        return self.xp.tensor(values, dtype=self.xp.float64)

    def cross(self, a, b):
        return self.xp.linalg.cross(a, b)

    def where_active(self, condition, value):
        return self.xp.where(condition, value, self.xp.zeros_like(value))


class SympyOps:
    """Formula operations on SymPy symbols: vectors are column matrices."""

    def __init__(self) -> None:
        import sympy
        self.sp = sympy

    def points(self, flat, k: int) -> list:
        return [self.sp.Matrix(flat[3 * i:3 * i + 3]) for i in range(k)]

    def matrix(self, flat, rows: int, cols: int):
        return self.sp.Matrix(rows, cols, list(flat))

    def columns(self, vectors: list):
        return self.sp.Matrix.hstack(*vectors)

    def vector(self, entries: list):
        return self.sp.Matrix(entries)

    def constant(self, values):
        return self.sp.Matrix(list(values))

    def eye(self, n: int):
        return self.sp.eye(n)

    def dot(self, a, b):
        return a.dot(b)

    def cross(self, a, b):
        return a.cross(b)

    def sqnorm(self, a):
        return sum(e ** 2 for e in a)

    def norm(self, a):
        return self.sp.sqrt(self.sqnorm(a))

    def det(self, a):
        return a.det()

    def log(self, a):
        return self.sp.log(a)

    def sin(self, a):
        return self.sp.sin(a)

    def cos(self, a):
        return self.sp.cos(a)

    def where_active(self, condition, value):
        # SymPy would need a Piecewise, which neither differentiates nor
        # prints into sensible straight-line C: the active branch only. The
        # samples keep every instance on it (checked when they are drawn).
        return value


# --- the formulas --------------------------------------------------------------

def inertia_gravity(o, x, x_hat):
    [p], [q] = o.points(x, 1), o.points(x_hat, 1)
    return 0.5 * MASS * o.sqnorm(p - q) - MASS * o.dot(o.constant(GRAVITY), p)


def spring(o, x):
    p = o.points(x, 2)
    return 0.5 * SPRING_K * (o.norm(p[1] - p[0]) - SPRING_REST) ** 2


def snh_psi(o, F):
    ic = o.sqnorm(F)
    J = o.det(F)
    return 0.5 * MU * (ic - 3) - 0.5 * MU * o.log(ic + 1) + \
        0.5 * LAM * (J - 1 - 0.75 * MU / LAM) ** 2


def snh_positions(o, x, dm_inv):
    p = o.points(x, 4)
    return snh_psi(o, o.columns([p[k] - p[0] for k in (1, 2, 3)])
                   @ o.matrix(dm_inv, 3, 3))


def snh_matrix(o, f):
    return snh_psi(o, o.matrix(f, 3, 3).T)  # column-major parameters


def baraff_witkin(o, x, duv_inv):
    q = o.points(x, 3)
    W = o.columns([q[1] - q[0], q[2] - q[0]]) @ o.matrix(duv_inv, 2, 2)
    su, sv = o.norm(W[:, 0]) - 1, o.norm(W[:, 1]) - 1
    return BW_AREA * (0.5 * BW_STRETCH * (su ** 2 + sv ** 2)
                      + 0.5 * BW_SHEAR * o.dot(W[:, 0], W[:, 1]) ** 2)


def bending(o, x):
    x0, x1, x2, x3 = o.points(x, 4)
    n1 = o.cross(x1 - x0, x2 - x0)
    n2 = o.cross(x3 - x0, x1 - x0)
    return BEND_K * BEND_REST * o.sqnorm(n1 / o.norm(n1) - n2 / o.norm(n2))


def distance2(kind: str, o, x):
    """Squared distance of point-point, point-line, point-plane and
    line-line pairs: the plain formulas of yasps.energies, no clamping to
    the edges or the triangle."""
    q = o.points(x, {"pp": 2, "pe": 3, "pt": 4, "ee": 4}[kind])
    if kind == "pp":
        return o.sqnorm(q[1] - q[0])
    if kind == "pe":
        u = q[2] - q[1]
        return o.sqnorm(o.cross(u, q[0] - q[1])) / o.sqnorm(u)
    n = o.cross(q[2] - q[1], q[3] - q[1]) if kind == "pt" else \
        o.cross(q[1] - q[0], q[3] - q[2])
    r = q[0] - q[1] if kind == "pt" else q[2] - q[0]
    return o.dot(r, n) ** 2 / o.sqnorm(n)


def barrier(kind: str, dhat: float, o, x):
    d = distance2(kind, o, x)
    return o.where_active(d < dhat, KAPPA * (d - dhat) ** 2 * o.log(d / dhat) ** 2)


def abd_orthogonality(o, a):
    A = o.matrix(a, 3, 3).T  # column-major parameters
    return 0.5 * ABD_K * o.sqnorm(A.T @ A - o.eye(3))


def pendulum(o, theta):
    pos = o.vector([o.sin(theta[0]) + o.sin(theta[1]),
                    -(o.cos(theta[0]) + o.cos(theta[1]))])
    return PENDULUM_G * pos[1] + o.sqnorm(pos - o.constant(PENDULUM_TARGET))


# --- instances -------------------------------------------------------------

Arrays = Tuple[np.ndarray, ...]


def _tets(rng: np.random.Generator, count: int) -> Arrays:
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(count, 4, 3))
    cur = rest @ (np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3)))
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    return cur.reshape(count, 12), dm_inv.reshape(count, 9)


def _matrices(rng: np.random.Generator, count: int) -> Arrays:
    M = np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3))
    return (np.transpose(M, (0, 2, 1)).reshape(count, 9),)  # column-major


def _inertia(rng: np.random.Generator, count: int) -> Arrays:
    return rng.normal(size=(count, 3)), rng.normal(size=(count, 3))


def _springs(rng: np.random.Generator, count: int) -> Arrays:
    return (rng.normal(size=(count, 6)),)


def _triangles(rng: np.random.Generator, count: int) -> Arrays:
    rest = np.array([[0, 0], [1, 0], [0, 1]], float)[None] + \
        rng.normal(scale=0.05, size=(count, 3, 2))
    cur = np.concatenate([rest, np.zeros((count, 3, 1))], axis=2) @ \
        (np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3)))
    inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2)], axis=2))
    return cur.reshape(count, 9), inv.reshape(count, 4)


def _hinges(rng: np.random.Generator, count: int) -> Arrays:
    hinge = np.array([[0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.6, -1, 0.4]], float)
    return ((hinge[None] + rng.normal(scale=0.05, size=(count, 4, 3))).reshape(count, 12),)


#: Nominal close pairs (point(s) first, as the distance functions take
#: them), perturbed per instance; their squared distances are about 0.01.
_PAIRS = {
    "pe": [[0.3, 0.1, 0.0], [0, 0, 0], [1, 0, 0]],
    "pt": [[0.2, 0.2, 0.1], [0, 0, 0], [1, 0, 0], [0, 1, 0]],
    "ee": [[0, 0, 0], [1, 0, 0], [0.5, -0.5, 0.1], [0.5, 0.5, 0.1]],
}


def _pairs(kind: str, dhat: float, rng: np.random.Generator, count: int) -> Arrays:
    if kind == "pp":
        x = rng.normal(scale=0.01, size=(count, 6))
    else:
        nominal = np.array(_PAIRS[kind], float)
        x = (nominal[None] + rng.normal(scale=0.02, size=(count,) + nominal.shape)
             ).reshape(count, -1)
    numpy_ops = ArrayOps(np)
    d = np.array([distance2(kind, numpy_ops, row) for row in x])
    assert (d > 0).all() and (d < dhat).all(), "a pair off the barrier's active branch"
    return (x,)


def _thetas(rng: np.random.Generator, count: int) -> Arrays:
    return (rng.uniform(-1, 1, size=(count, 2)),)


# --- yasps scenes -------------------------------------------------------------

Built = Tuple[Any, Any, Any, Any]  # scene, energy's owner, target, energy


def _elements(points: np.ndarray):
    """A scene with ``count * arity`` vertices and ``count`` elements that
    JOIN ``arity`` of them each, from the corner positions (count, arity, 3):
    the scene, the elements, the positions and the element's corners."""
    count, arity = points.shape[:2]
    s = yasps.scene("bench")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=count * arity)
    e = m.addPrimitive("e", numInstances=count)
    x = v.addAttribute("x", rows=3, cols=1)
    x.updateValue(points.reshape(-1, 3))
    conn = e.addConnectivity("e2v", v, np.arange(count * arity).reshape(count, arity), arity)
    return s, e, x, e.addAttribute("c", through=conn, source=x)


def _one_primitive(values: np.ndarray, rows: int, cols: int):
    """A scene with one primitive and its attribute ``p`` (rows x cols),
    set from column-major flat values (count, rows * cols)."""
    s = yasps.scene("bench")
    e = s.addMesh("m").addPrimitive("e", numInstances=len(values))
    p = e.addAttribute("p", rows=rows, cols=cols)
    p.updateValue(np.transpose(values.reshape(-1, cols, rows), (0, 2, 1)))
    return s, e, p


def _inertia_scene(x: np.ndarray, x_hat: np.ndarray) -> Built:
    s, v, p = _one_primitive(x, 3, 1)
    xh = v.addConstant("xh", rows=3)
    xh.updateValue(x_hat)
    return s, v, p, E.inertia(p, xh, MASS) + E.gravity(p, MASS, np.array(GRAVITY))


def _spring_scene(x: np.ndarray) -> Built:
    s, e, p, c = _elements(x.reshape(len(x), 2, 3))
    return s, e, p, E.mass_spring(c, SPRING_REST, SPRING_K)


def _snh_parts(x: np.ndarray, dm_inv: np.ndarray):
    s, e, p, c = _elements(x.reshape(len(x), 4, 3))
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv.reshape(-1, 3, 3))
    return s, e, p, E.deformation_gradient(c, inv)


def _snh_scene(x: np.ndarray, dm_inv: np.ndarray) -> Built:
    s, e, p, F = _snh_parts(x, dm_inv)
    return s, e, p, E.stable_neo_hookean(F, MU, LAM, 1.0)


def _snh_via_F_scene(x: np.ndarray, dm_inv: np.ndarray) -> Built:
    """The paper's section 10.4 trick: F as its own attribute, JOINed by a
    one-to-one primitive, so the projection is 9x9 in reduced space."""
    s, e, p, F = _snh_parts(x, dm_inv)
    e.addAttribute("F", computed_attribute=F)
    fe = s.m.addPrimitive("fe", numInstances=len(x))
    fe2t = fe.addConnectivity("fe2t", e, np.arange(len(x)), 1)
    jf = fe.addAttribute("F", through=fe2t, source=e["F"])
    return s, fe, p, E.stable_neo_hookean(jf.resize(3, 3), MU, LAM, 1.0)


def _snh_F_scene(f: np.ndarray) -> Built:
    s, e, F = _one_primitive(f, 3, 3)
    return s, e, F, E.stable_neo_hookean(F, MU, LAM, 1.0)


def _cloth_scene(x: np.ndarray, duv_inv: np.ndarray) -> Built:
    s, e, p, c = _elements(x.reshape(len(x), 3, 3))
    inv = e.addConstant("inv", rows=2, cols=2)
    inv.updateValue(duv_inv.reshape(-1, 2, 2))
    return s, e, p, E.baraff_witkin(c, inv, BW_AREA, BW_STRETCH, BW_SHEAR)


def _bending_scene(x: np.ndarray) -> Built:
    s, e, p, c = _elements(x.reshape(len(x), 4, 3))
    return s, e, p, E.dihedral_bending(c, BEND_REST, BEND_K)


_DISTANCES = {"pp": E.point_point_distance2, "pe": E.point_edge_distance2,
              "pt": E.point_triangle_distance2, "ee": E.edge_edge_distance2}


def _barrier_scene(kind: str, dhat: float, x: np.ndarray) -> Built:
    s, e, p, c = _elements(x.reshape(len(x), -1, 3))
    rows = [c.row(i).T for i in range(c.rows)]
    return s, e, p, E.ipc_barrier(_DISTANCES[kind](*rows), dhat, KAPPA)


def _abd_scene(a: np.ndarray) -> Built:
    s, b, A = _one_primitive(a, 3, 3)
    return s, b, A, E.abd_orthogonality(A, ABD_K)


def _pendulum_scene(theta: np.ndarray) -> Built:
    s, bob, t = _one_primitive(theta, 2, 1)
    a, b = t[0], t[1]
    pos = bob.addAttribute("position", computed_attribute=yasps.vstack(
        [a.sin() + b.sin(), -(a.cos() + b.cos())]))
    return s, bob, t, PENDULUM_G * pos[1] + \
        (pos - np.array(PENDULUM_TARGET)).squaredNorm()


# --- the cases ------------------------------------------------------------------

@dataclass
class Case:
    """One energy: its instances, yasps scene and independent formula."""
    name: str
    sample: Callable[[np.random.Generator, int], Arrays]
    scene: Callable[..., Built]
    formula: Callable[..., Any]

    def instances(self, count: int, seed: int = 0) -> Arrays:
        """The same ``count`` instances on every call (and in every
        script): parameters first, then constants, each (count, k)."""
        return self.sample(np.random.default_rng(seed), count)

    def build(self, arrays: Arrays) -> "YaspsEnergy":
        """yasps' scene of these instances, with the energy registered."""
        return YaspsEnergy(*self.scene(*arrays))


DHAT_PP, DHAT = 1.0, 0.1

CASES: List[Case] = [
    Case("inertia + gravity (3)", _inertia, _inertia_scene, inertia_gravity),
    Case("mass-spring (6)", _springs, _spring_scene, spring),
    Case("stable Neo-Hookean (x, 12)", _tets, _snh_scene, snh_positions),
    Case("stable Neo-Hookean (x via F, 12)", _tets, _snh_via_F_scene, snh_positions),
    Case("stable Neo-Hookean (F, 9)", _matrices, _snh_F_scene, snh_matrix),
    Case("Baraff-Witkin cloth (9)", _triangles, _cloth_scene, baraff_witkin),
    Case("dihedral bending (12)", _hinges, _bending_scene, bending),
    Case("IPC barrier PP (6)", partial(_pairs, "pp", DHAT_PP),
         partial(_barrier_scene, "pp", DHAT_PP), partial(barrier, "pp", DHAT_PP)),
    Case("IPC barrier PE (9)", partial(_pairs, "pe", DHAT),
         partial(_barrier_scene, "pe", DHAT), partial(barrier, "pe", DHAT)),
    Case("IPC barrier PT (12)", partial(_pairs, "pt", DHAT),
         partial(_barrier_scene, "pt", DHAT), partial(barrier, "pt", DHAT)),
    Case("IPC barrier EE (12)", partial(_pairs, "ee", DHAT),
         partial(_barrier_scene, "ee", DHAT), partial(barrier, "ee", DHAT)),
    Case("ABD orthogonality (A, 9)", _matrices, _abd_scene, abd_orthogonality),
    Case("pendulum (2 angles)", _thetas, _pendulum_scene, pendulum),
]


# --- yasps kernels and checks ---------------------------------------------------

class YaspsEnergy:
    """A yasps scene whose only energy is registered and minimised over one
    target, with its compiled local-derivative kernels."""

    def __init__(self, scene, owner, target, energy) -> None:
        self.scene = scene
        self.count = owner.numInstances
        self.attr = owner.addAttribute("energy", computed_attribute=energy)
        scene.addEnergy(self.attr)
        scene.addMinimizeTarget([target])
        self.base = "::".join("@" + p for p in owner.path + ["energy"])

    def path(self, kernel: str) -> str:
        """The kernel ``grad``, ``hess`` or ``hess_proj`` of the energy."""
        return f"{self.base}__{kernel}"

    def kernels(self, names: Sequence[str]) -> Tuple[float, Any, List[Callable[[], None]]]:
        """Compiles the named kernels (cold unless the cache has them): the
        seconds this took, the library, and per kernel a call that runs it
        on every instance on one thread into a fresh output buffer."""
        paths = [self.path(n) for n in names]
        t0 = time.perf_counter()
        kernels = compile_cpu(emit_scene(self.scene), paths, self.scene.name,
                              DIFFERENTIATION_PIPELINE)
        seconds = time.perf_counter() - t0
        launches = []
        for path in paths:
            kernel = kernels.kernel(path)
            out = np.empty(self.count * kernel.rows * kernel.cols,
                           dtype=kernel.out_dtype)
            buffers = [out if a.kind is ArgumentKind.out else host_input(self.scene, a)
                       for a in kernel.arguments]
            launches.append(partial(launch, kernels, path, self.count, buffers, 1))
        return seconds, kernels.library, launches

    def derivatives(self):
        """yasps' local gradients (N, n) and Hessians (N, n, n), one thread."""
        return self.scene.energyDerivatives(self.attr, threads=1)


def check_agrees(gradient: np.ndarray, hessian: np.ndarray, check,
                 rtol: float = 1e-7) -> None:
    """Asserts that a peer's per-instance gradient (N, n) and Hessian
    (N, n, n) agree with yasps' local derivatives ``check``."""
    np.testing.assert_allclose(check.gradient, gradient, rtol=rtol,
                               atol=rtol * np.abs(gradient).max())
    np.testing.assert_allclose(check.hessian, hessian.reshape(check.hessian.shape),
                               rtol=rtol, atol=rtol * np.abs(hessian).max())

