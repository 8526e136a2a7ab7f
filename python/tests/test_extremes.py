"""Derivatives and projections at the extremes, in f64 and in f32, against
mpmath at 60 digits evaluated on the same floating-point inputs (in f32:
the inputs rounded to f32, which is what an f32 kernel computes on): the
IPC barrier from d/dhat = 1e-12 to 1 - 1e-8, stable Neo-Hookean near and
past inversion and at |F| ~ 1e3, a sliver tet, and PSD projections of
matrices with repeated and clustered eigenvalues at norms 1, 1e-300 and
1e300 (f32: 1e-30 and 1e30, its range). Each check states the bound its
precision must meet and why, or, where f32 has no correct digits left, that
it breaks there (docs/accuracy.md)."""

import mpmath
import numpy as np
import pytest

import yasps
from yasps import energies as E

EPS = np.finfo(float).eps
EPS32 = float(np.finfo(np.float32).eps)
mpmath.mp.dps = 60


def scalar_energy(make, values, rows=1, cols=1, precision="f64"):
    """energyDerivatives of ``make(x)`` over one target x per instance."""
    values = np.asarray(values, float)
    s = yasps.scene("extremes", precision=precision)
    p = s.addMesh("m").addPrimitive("p", numInstances=len(values))
    x = p.addAttribute("x", rows=rows, cols=cols)
    x.updateValue(values.reshape(len(values), rows, cols))
    s.addEnergy(p.addAttribute("energy", computed_attribute=make(x)))
    s.addMinimizeTarget(x)
    return s.energyDerivatives(s.m.p["energy"])


def mp_derivatives(f, point):
    """Value, gradient and Hessian of ``f`` (a function of len(point) mpf)
    at ``point`` (floats, taken exactly), by mpmath's high-precision
    differences."""
    x = [mpmath.mpf(float(v)) for v in point]
    n = len(x)
    value = f(*x)
    grad = [mpmath.diff(f, x, tuple(int(k == i) for k in range(n)))
            for i in range(n)]
    hess = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(i, n):
            orders = [0] * n
            orders[i] += 1
            orders[j] += 1
            hess[i][j] = hess[j][i] = mpmath.diff(f, x, tuple(orders))
    as_float = lambda a: np.array(a, dtype=float)  # noqa: E731
    return float(value), as_float(grad), as_float([[float(v) for v in row]
                                                   for row in hess])


def relative(got, want) -> float:
    """Largest error relative to the largest reference entry."""
    return float(np.abs(np.asarray(got) - want).max() /
                 max(np.abs(want).max(), 1e-300))


# --------------------------------------------------------------- barrier

DHAT = 1e-6   # a squared distance: dhat = 1 mm
KAPPA = 1e3


@pytest.mark.parametrize("ratio", [1e-12, 1e-8, 1e-4, 0.5, 1 - 1e-4,
                                   1 - 1e-8])
def test_barrier_against_mpmath(ratio):
    """kappa (d - dhat)^2 log^2(d / dhat). log(d / dhat) is computed from
    the rounded quotient, whose error eps is relative to 1: the log's
    relative error is eps / |log(d / dhat)|, which near d = dhat is
    eps / (1 - d/dhat). That is the bound, with a small constant."""
    d = ratio * DHAT
    got = scalar_energy(lambda x: E.ipc_barrier(x, DHAT, KAPPA), [[d]])

    def barrier(t):
        return KAPPA * (t - DHAT) ** 2 * mpmath.log(t / DHAT) ** 2

    value, grad, hess = mp_derivatives(barrier, [d])
    bound = 16 * EPS * (1 + 1 / abs(np.log(ratio)))
    assert relative(got.value[0], value) <= bound
    assert relative(got.gradient[0], grad) <= bound
    assert relative(got.hessian[0], hess) <= bound


# ----------------------------------------------------- stable Neo-Hookean

MU, LAM = 1.0, 10.0


def snh_mp(*F):
    """Stable Neo-Hookean of a column-major 3x3 F, unit volume (the
    paper's eq. 10), in mpmath."""
    M = mpmath.matrix(3, 3)
    for c in range(3):
        for r in range(3):
            M[r, c] = F[3 * c + r]
    ic = sum(v * v for v in F)
    alpha = 1 + mpmath.mpf(3) * MU / (4 * LAM)
    J = mpmath.det(M)
    return (MU / 2 * (ic - 3) - MU / 2 * mpmath.log(ic + 1)
            + LAM / 2 * (J - alpha) ** 2)


def rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q))


CASES = {
    # det F = 1e-8: a tet squashed to a hundred-millionth of its volume.
    "near inversion": rotation(1) @ np.diag([1.0, 1.0, 1e-8]),
    # det F = -0.5: inverted.
    "inverted": rotation(2) @ np.diag([1.0, 1.0, -0.5]),
    # |F| ~ 1e3: stretched a thousandfold.
    "stretched": rotation(3) @ np.diag([1e3, 8e2, 1.2e3]) @ rotation(4),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_stable_neo_hookean_against_mpmath(case):
    """Relative to the largest entry: each of value, gradient and Hessian
    within 64 eps. Stable Neo-Hookean has no singularity at J <= 0 (its
    point), and its terms are sums of products of F's entries, whose
    rounding stays at a few eps of the largest term."""
    F = CASES[case]
    got = scalar_energy(lambda x: E.stable_neo_hookean(x, MU, LAM, 1.0),
                        [F], rows=3, cols=3)
    value, grad, hess = mp_derivatives(snh_mp, F.T.reshape(-1))
    bound = 64 * EPS
    assert relative(got.value[0], value) <= bound
    assert relative(got.gradient[0], grad) <= bound
    assert relative(got.hessian[0], hess) <= bound


# A tet 1e-8 high over a unit triangle, its positions perturbed by 1e-9.
SLIVER_REST = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 1e-8]])
SLIVER_DM = (SLIVER_REST[1:] - SLIVER_REST[0]).T
SLIVER_X = SLIVER_REST + 1e-9 * np.random.default_rng(5).standard_normal((4, 3))


def sliver_derivatives(precision):
    """energyDerivatives of stable Neo-Hookean on the sliver tet, its four
    vertices the target, computed in ``precision``."""
    s = yasps.scene("sliver", precision=precision)
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=4)
    pos = v.addAttribute("x", rows=3)
    pos.updateValue(SLIVER_X)
    t = m.addPrimitive("t", numInstances=1)
    t.addConstant("inv", rows=3, cols=3).updateValue(
        np.linalg.inv(SLIVER_DM)[None])
    corners = t.addAttribute("c", through=t.addConnectivity(
        "t2v", v, [[0, 1, 2, 3]], 4), source=pos)
    s.addEnergy(t.addAttribute("snh", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(corners, t["inv"]), MU, LAM, 1.0)))
    s.addMinimizeTarget(pos)
    return s.energyDerivatives(s.m.t["snh"])


def test_sliver_tet_against_mpmath():
    """A tet of height 1e-8 over a unit triangle: the rest edge matrix Dm
    has condition ~1e8, and F = Ds Dm^-1 amplifies the rounding of the
    position differences by it. Bound: 16 eps cond(Dm) relative to the
    largest entry, the f64 price of the shape."""
    x, Dm = SLIVER_X, SLIVER_DM
    inv = np.linalg.inv(Dm)
    got = sliver_derivatives("f64")
    inv_mp = mpmath.matrix(inv.tolist())

    def energy(*q):
        p = [mpmath.matrix(q[3 * k:3 * k + 3]) for k in range(4)]
        Ds = mpmath.matrix(3, 3)
        for c in range(3):
            for r in range(3):
                Ds[r, c] = p[c + 1][r] - p[0][r]
        F = Ds * inv_mp
        return snh_mp(*[F[r, c] for c in range(3) for r in range(3)])

    value, grad, hess = mp_derivatives(energy, x.reshape(-1))
    bound = 16 * EPS * np.linalg.cond(Dm)
    assert relative(got.value[0], value) <= bound
    assert relative(got.gradient[0], grad) <= bound
    assert relative(got.hessian[0], hess) <= bound


# ------------------------------------------------------------ projection

N = 12


def projection_cases():
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((N, N)))
    spectra = {
        "repeated": [3, 3, 3, -1, -1, -1, 0, 0, 2, 2, 2, 2],
        "clustered": 1 + 1e-12 * np.arange(N) - 2 * (np.arange(N) % 2),
        "spread": np.logspace(-8, 8, N) * (-1) ** np.arange(N),
    }
    return {name: q @ np.diag(np.asarray(lam, float)) @ q.T
            for name, lam in spectra.items()}


def mp_clamped(A: np.ndarray) -> np.ndarray:
    """The PSD projection V max(L, 0) V^T at 60 digits."""
    lam, V = mpmath.eigsy(mpmath.matrix(A.tolist()))
    P = V * mpmath.diag([max(x, 0) for x in lam]) * V.T
    return np.array(P.tolist(), dtype=float)


def quadratic_derivatives(A: np.ndarray, precision: str):
    """energyDerivatives of x^T A x / 2 over one N-vector x, in
    ``precision``: its Hessian is A and its projected Hessian A's PSD
    projection."""
    s = yasps.scene("projection", precision=precision)
    p = s.addMesh("m").addPrimitive("p", numInstances=1)
    x = p.addAttribute("x", rows=N)
    x.updateValue(np.zeros((1, N)))
    a = p.addConstant("A", rows=N, cols=N)
    a.updateValue(A[None])
    s.addEnergy(p.addAttribute("q", computed_attribute=0.5 * (x.T * a * x)))
    s.addMinimizeTarget(x)
    return s.energyDerivatives(s.m.p["q"])


@pytest.mark.parametrize("scale", [1.0, 1e-300, 1e300])
@pytest.mark.parametrize("case", ["repeated", "clustered", "spread"])
def test_projection_against_mpmath(case, scale):
    """Projection onto the PSD cone is 1-Lipschitz, so a backward-stable
    eigensolver gives it to a few eps of |A| whatever the eigenvalues'
    multiplicities: bound 64 eps |A|_max, at every scale the floating
    point range allows (1e-300 failed by 30% before the kernels scaled the
    matrix into range)."""
    A = projection_cases()[case] * scale
    A = 0.5 * (A + A.T)
    got = quadratic_derivatives(A, "f64")
    assert relative(got.hessian[0], A) <= EPS
    want = mp_clamped(A)
    assert np.abs(got.projectedHessian[0] - want).max() <= \
        64 * EPS * np.abs(A).max()


# ------------------------------------------------------------------ f32

def f32(values) -> np.ndarray:
    """``values`` rounded to f32, as an f32 kernel loads them."""
    return np.asarray(values, dtype=np.float32).astype(float)


@pytest.mark.parametrize("ratio", [1e-12, 1e-8, 1e-4, 0.5, 1 - 1e-4])
def test_barrier_in_f32_against_mpmath(ratio):
    """The f64 bound with f32's eps: 16 eps32 (1 + 1 / |log(d / dhat)|),
    against mpmath at the f32-rounded distance. At 1 - 1e-4 that is 2% of
    a barrier that is 1e-16 of its size at d = dhat/2: f32 keeps few digits
    of the barrier near dhat, where it is negligible (test below)."""
    d = float(f32(ratio * DHAT))
    got = scalar_energy(lambda x: E.ipc_barrier(x, DHAT, KAPPA), [[d]],
                        precision="f32")

    def barrier(t):
        return KAPPA * (t - DHAT) ** 2 * mpmath.log(t / DHAT) ** 2

    value, grad, hess = mp_derivatives(barrier, [d])
    bound = 16 * EPS32 * (1 + 1 / abs(np.log(d / DHAT)))
    assert relative(got.value[0], value) <= bound
    assert relative(got.gradient[0], grad) <= bound
    assert relative(got.hessian[0], hess) <= bound


def test_barrier_in_f32_breaks_only_where_it_vanishes():
    """At d/dhat = 1 - 1e-8, f32 cannot tell d from dhat (their ratio
    rounds to 1 within eps32 = 1.2e-7): the barrier's value, 1e-32 of its
    size at dhat/2, has no correct digit, but its error is below eps32 of
    that size, so the energy and forces it adds are right to f32."""
    d = (1 - 1e-8) * DHAT
    got = scalar_energy(lambda x: E.ipc_barrier(x, DHAT, KAPPA), [[d]],
                        precision="f32")
    half = scalar_energy(lambda x: E.ipc_barrier(x, DHAT, KAPPA),
                         [[0.5 * DHAT]])
    for ours, scale in ((got.value, half.value), (got.gradient, half.gradient),
                        (got.hessian, half.hessian)):
        assert np.abs(ours).max() <= EPS32 * np.abs(scale).max()


@pytest.mark.parametrize("case", sorted(CASES))
def test_stable_neo_hookean_in_f32_against_mpmath(case):
    """64 eps32 of the largest entry, at the f32-rounded F (the f64 test's
    bound and reasoning with f32's eps)."""
    F = f32(CASES[case])
    got = scalar_energy(lambda x: E.stable_neo_hookean(x, MU, LAM, 1.0),
                        [F], rows=3, cols=3, precision="f32")
    value, grad, hess = mp_derivatives(snh_mp, F.T.reshape(-1))
    bound = 64 * EPS32
    assert relative(got.value[0], value) <= bound
    assert relative(got.gradient[0], grad) <= bound
    assert relative(got.hessian[0], hess) <= bound


def test_sliver_tet_breaks_in_f32():
    """f32 has eps32 cond(Dm) = 1.2e-7 x 1e8 > 1 on the 1e-8-high sliver:
    no correct digit (its positions' 1e-9 perturbation is below their f32
    rounding). The f32 derivatives are off by more than 10% of the
    largest entry: such shapes need f64 (docs/accuracy.md)."""
    grads = {p: sliver_derivatives(p).gradient[0] for p in ("f64", "f32")}
    assert EPS32 * np.linalg.cond(SLIVER_DM) > 1
    assert relative(grads["f32"], grads["f64"]) > 0.1


@pytest.mark.parametrize("scale", [1.0, 1e-30, 1e30])
@pytest.mark.parametrize("case", ["repeated", "clustered", "spread"])
def test_projection_in_f32_against_mpmath(case, scale):
    """The f64 test's bound with f32's eps, 64 eps32 |A|_max, at the
    f32-rounded A, over f32's range (1e-30..1e30: its squares stay
    normal where the kernels scale them)."""
    A = projection_cases()[case] * scale
    A = f32(0.5 * (A + A.T))
    got = quadratic_derivatives(A, "f32")
    want = mp_clamped(A)
    assert np.abs(got.projectedHessian[0] - want).max() <= \
        64 * EPS32 * np.abs(A).max()
