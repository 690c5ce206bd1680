"""The implicit integrator's conditions: forces and Jacobians against finite differences and
tests/reference/implicit_energies.py, the rest state, the pattern and the colouring."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.integrators.implicit.kernels.implicit_coloring import greedy_colors
from clothtool.integrators.implicit.kernels.implicit_energies import drag_terms, hinge_terms, triangle_terms
from clothtool.integrators.implicit.pattern import build_pattern, color_elements
from clothtool.integrators.implicit.rest import build_rest_shape, dihedral_angles, triangle_corner_uvs
from clothtool.mesh.shapes import grid
from tests.integrators.test_implicit_setup import grid_fabric
from tests.reference import implicit_cg as ref_cg
from tests.reference import implicit_coloring as ref_coloring
from tests.reference import implicit_energies as ref

EPS = 1e-6  # central differences: truncation ~EPS^2, rounding ~1e-16/EPS, relative
FD_RTOL = 1e-6
STRETCH_U, STRETCH_V, SHEAR, DAMPING_TIME = 3.0, 2.0, 0.7, 0.05


def soup(rng, count):
    """``count`` separate random rest triangles (3 particles each) and a deformed state."""
    rest = rng.normal(size=(3 * count, 3))
    triangles = np.arange(3 * count, dtype=np.int32).reshape(-1, 3)
    shape = build_rest_shape(rest, triangles)
    # stretch some, compress others, rotate and shear: a random linear map per triangle + noise
    x = rest.copy()
    for t in range(count):
        matrix = np.eye(3) * rng.uniform(0.7, 1.3) + rng.normal(0, 0.2, (3, 3))
        x[3 * t:3 * t + 3] = rest[3 * t:3 * t + 3] @ matrix.T + rng.normal(0, 0.05, 3)
    return shape, x


def hinge_soup(rng, count, flat=False):
    """``count`` separate hinges (wing a, wing b, edge start, edge end) and their rest data."""
    x = np.zeros((4 * count, 3))
    for p in range(count):
        s, e = rng.normal(size=3), rng.normal(size=3)
        axis = (e - s) / np.linalg.norm(e - s)
        side = np.cross(axis, rng.normal(size=3))
        side /= np.linalg.norm(side)
        up = np.cross(axis, side)
        lift = (0.0, 0.0) if flat else (rng.uniform(0.2, 1.0), rng.uniform(-1.0, 1.0))
        along = rng.uniform(0.2, 0.8, 2)
        wa = s + along[0] * (e - s) + rng.uniform(0.5, 1.5) * side + lift[0] * up
        wb = s + along[1] * (e - s) - rng.uniform(0.5, 1.5) * side + lift[1] * up
        x[4 * p:4 * p + 4] = [wa, wb, s, e]
    hinges = np.arange(4 * count, dtype=np.int32).reshape(-1, 4)
    return hinges, x


def run_triangles(shape, x, v, exact, x_weight=1.0, v_weight=0.0, compression=1.0):
    """Kernel force (n,3), (df/dx) v (n,3) and the dense -(x_weight df/dx + v_weight df/dv)."""
    n = x.shape[0]
    pattern = build_pattern(n, shape.triangles, np.zeros((0, 4), np.int32))
    order, offsets = color_elements(shape.triangles, n)
    force, jacobian_v, blocks = np.zeros((n, 3)), np.zeros((n, 3)), pattern.empty_values()
    triangle_terms(shape.triangles, shape.tri_dinv, shape.tri_area, pattern.triangle_slot, order, offsets,
                   np.ascontiguousarray(x), np.ascontiguousarray(v), STRETCH_U, STRETCH_V, compression, SHEAR, DAMPING_TIME,
                   x_weight, v_weight, exact, force, jacobian_v, blocks)
    return force, jacobian_v, ref_cg.to_scipy(pattern.row_offsets, pattern.columns, blocks).toarray()


def run_hinges(hinges, rest_angle, weight, x, v, bend=1.3, x_weight=1.0, v_weight=0.0):
    n = x.shape[0]
    pattern = build_pattern(n, np.zeros((0, 3), np.int32), hinges)
    order, offsets = color_elements(hinges, n)
    force, jacobian_v, blocks = np.zeros((n, 3)), np.zeros((n, 3)), pattern.empty_values()
    hinge_terms(hinges, rest_angle, weight, pattern.hinge_slot, order, offsets, np.ascontiguousarray(x),
                np.ascontiguousarray(v), bend, DAMPING_TIME, x_weight, v_weight, force, jacobian_v, blocks)
    return force, jacobian_v, ref_cg.to_scipy(pattern.row_offsets, pattern.columns, blocks).toarray()


def finite_difference(force_of, y):
    """(3n,3n) central-difference Jacobian of force_of (n,3) -> (n,3) at y."""
    flat = y.reshape(-1)
    columns = []
    for j in range(flat.size):
        step = np.zeros_like(flat)
        step[j] = EPS
        columns.append((force_of((flat + step).reshape(y.shape)) - force_of((flat - step).reshape(y.shape))).reshape(-1) / (2 * EPS))
    return np.stack(columns, axis=1)


def assert_relative(actual, expected, rtol, what):
    scale = np.abs(expected).max()
    error = np.abs(actual - expected).max()
    assert error <= rtol * scale, f"{what}: max error {error:.3g} vs scale {scale:.3g}"


# ----------------------------------------------------------------- stretch and shear
@pytest.mark.parametrize("seed, compression", [(0, 1.0), (1, 1.0), (2, 0.1)])
def test_stretch_shear_dfdx_matches_finite_differences(seed, compression):
    """With compression < 1 the stiffness changes where an axis passes its rest length; the
    random triangles stay clear of that kink (checked), so central differences apply."""
    rng = np.random.default_rng(seed)
    shape, x = soup(rng, 6)
    for t in range(shape.triangle_count):
        conditions = ref.triangle_conditions(x, shape.triangles[t], shape.tri_dinv[t], shape.tri_area[t])
        assert all(abs(c[0] / shape.tri_area[t]) > 10 * EPS for c in conditions[:2])
    zero = np.zeros_like(x)  # v = 0: the damping force and its x-derivatives vanish
    _, _, minus_dfdx = run_triangles(shape, x, zero, exact=True, compression=compression)
    numeric = finite_difference(lambda y: run_triangles(shape, y, zero, exact=True, compression=compression)[0], x)
    assert_relative(-minus_dfdx, numeric, FD_RTOL, "df/dx")


@pytest.mark.parametrize("seed", [3, 4])
def test_stretch_shear_dfdv_matches_finite_differences(seed):
    rng = np.random.default_rng(seed)
    shape, x = soup(rng, 6)
    v = rng.normal(size=x.shape)
    _, _, minus_dfdv = run_triangles(shape, x, v, exact=False, x_weight=0.0, v_weight=1.0)
    numeric = finite_difference(lambda w: run_triangles(shape, x, w, exact=False)[0], v)
    assert_relative(-minus_dfdv, numeric, FD_RTOL, "df/dv")
    assert np.abs(numeric).max() > 0.1 * DAMPING_TIME  # the damping force is there to be checked


@pytest.mark.parametrize("seed", [5, 6])
def test_stretch_shear_force_is_minus_energy_gradient(seed):
    rng = np.random.default_rng(seed)
    shape, x = soup(rng, 5)
    force, _, _ = run_triangles(shape, x, np.zeros_like(x), exact=False)

    def energy(y):
        return np.array([ref.triangle_energy(y, shape.triangles, shape.tri_dinv, shape.tri_area, STRETCH_U, STRETCH_V, SHEAR)])

    gradient = finite_difference(energy, x).reshape(x.shape)
    assert_relative(force, -gradient, FD_RTOL, "force")


@pytest.mark.parametrize("exact, compression", [(False, 1.0), (True, 1.0), (False, 0.1)])
def test_triangle_kernel_matches_reference(exact, compression):
    rng = np.random.default_rng(7)
    shape, x = soup(rng, 8)
    v = rng.normal(size=x.shape)
    force, jacobian_v, minus_dfdx = run_triangles(shape, x, v, exact, compression=compression)
    _, _, minus_dfdv = run_triangles(shape, x, v, exact, x_weight=0.0, v_weight=1.0, compression=compression)
    ref_force, ref_dfdx, ref_dfdv = ref.triangle_terms(shape.triangles, shape.tri_dinv, shape.tri_area, x, v,
                                                       STRETCH_U, STRETCH_V, SHEAR, DAMPING_TIME, exact, compression)
    assert_relative(force, ref_force, 1e-12, "force")
    assert_relative(-minus_dfdx, ref_dfdx, 1e-12, "df/dx")
    assert_relative(-minus_dfdv, ref_dfdv, 1e-12, "df/dv")
    assert_relative(jacobian_v.reshape(-1), ref_dfdx @ v.reshape(-1), 1e-12, "df/dx v")


def test_filtered_dfdx_is_negative_semidefinite_and_exact_is_not():
    rng = np.random.default_rng(8)
    shape, x = soup(rng, 8)
    zero = np.zeros_like(x)
    filtered = run_triangles(shape, x, zero, exact=False)[2]  # -df/dx
    exact = run_triangles(shape, x, zero, exact=True)[2]
    assert np.allclose(filtered, filtered.T, atol=1e-12)
    assert np.linalg.eigvalsh(filtered).min() > -1e-10 * np.abs(filtered).max()
    assert np.linalg.eigvalsh(exact).min() < -1e-3 * np.abs(exact).max()  # compression: indefinite


# ----------------------------------------------------------------- bend
@pytest.mark.parametrize("seed", [0, 1])
def test_bend_dfdx_matches_finite_differences(seed):
    """The kernel's Gauss-Newton df/dx plus the dropped -k C d2theta/dx2 term (reference) is
    the exact Jacobian of the kernel's force."""
    rng = np.random.default_rng(seed)
    hinges, x = hinge_soup(rng, 4)
    rest_angle = rng.uniform(-0.5, 0.5, 4)
    weight = rng.uniform(0.5, 2.0, 4)
    bend = 1.3
    zero = np.zeros_like(x)
    _, _, minus_dfdx = run_hinges(hinges, rest_angle, weight, x, zero, bend)
    numeric = finite_difference(lambda y: run_hinges(hinges, rest_angle, weight, y, zero, bend)[0], x)
    _, ref_exact, _ = ref.hinge_terms(hinges, rest_angle, bend * weight, x, zero, DAMPING_TIME, exact=True)
    _, ref_gauss_newton, _ = ref.hinge_terms(hinges, rest_angle, bend * weight, x, zero, DAMPING_TIME, exact=False)
    assert_relative(ref_exact, numeric, FD_RTOL, "reference exact df/dx")
    assert_relative(-minus_dfdx, ref_gauss_newton, 1e-12, "kernel df/dx")
    assert_relative(-minus_dfdx + (ref_exact - ref_gauss_newton), numeric, FD_RTOL, "kernel df/dx + dropped term")


def test_bend_dfdx_is_exact_at_the_rest_angle():
    rng = np.random.default_rng(2)
    hinges, x = hinge_soup(rng, 4, flat=True)
    rest_angle = dihedral_angles(x, hinges)
    assert np.abs(rest_angle).max() < 1e-12
    zero = np.zeros_like(x)
    weight = np.ones(4)
    _, _, minus_dfdx = run_hinges(hinges, rest_angle, weight, x, zero)
    numeric = finite_difference(lambda y: run_hinges(hinges, rest_angle, weight, y, zero)[0], x)
    assert_relative(-minus_dfdx, numeric, FD_RTOL, "df/dx at rest")


@pytest.mark.parametrize("seed", [3, 4])
def test_bend_force_and_dfdv(seed):
    rng = np.random.default_rng(seed)
    hinges, x = hinge_soup(rng, 4)
    rest_angle = rng.uniform(-0.5, 0.5, 4)
    weight = rng.uniform(0.5, 2.0, 4)
    v = rng.normal(size=x.shape)
    force0, _, _ = run_hinges(hinges, rest_angle, weight, x, np.zeros_like(x))
    gradient = finite_difference(lambda y: np.array([ref.hinge_energy(y, hinges, rest_angle, 1.3 * weight)]), x)
    assert_relative(force0, -gradient.reshape(x.shape), FD_RTOL, "force")
    force, jacobian_v, _ = run_hinges(hinges, rest_angle, weight, x, v)
    _, _, minus_dfdv = run_hinges(hinges, rest_angle, weight, x, v, x_weight=0.0, v_weight=1.0)
    numeric = finite_difference(lambda w: run_hinges(hinges, rest_angle, weight, x, w)[0], v)
    assert_relative(-minus_dfdv, numeric, FD_RTOL, "df/dv")
    ref_force, ref_dfdx, _ = ref.hinge_terms(hinges, rest_angle, 1.3 * weight, x, v, DAMPING_TIME, exact=False)
    assert_relative(force, ref_force, 1e-12, "force with damping")
    assert_relative(jacobian_v.reshape(-1), ref_dfdx @ v.reshape(-1), 1e-12, "df/dx v")


# ----------------------------------------------------------------- drag
def test_drag_matches_reference_and_finite_differences():
    rng = np.random.default_rng(9)
    shape, x = soup(rng, 4)
    v = rng.normal(size=x.shape)
    wind = np.array([0.3, -0.2, 0.5])
    n = x.shape[0]
    pattern = build_pattern(n, shape.triangles, np.zeros((0, 4), np.int32))
    order, offsets = color_elements(shape.triangles, n)

    def run(w, v_weight=1.0):
        force, blocks = np.zeros((n, 3)), pattern.empty_values()
        drag_terms(shape.triangles, pattern.triangle_slot, order, offsets, share, x, np.ascontiguousarray(w), wind, 0.8,
                   lift, 0.7, v_weight, force, blocks)
        return force, ref_cg.to_scipy(pattern.row_offsets, pattern.columns, blocks).toarray()

    lift = 0.4
    share = rng.uniform(0.75, 1.5, n)
    force, minus_dfdv = run(v)
    ref_force, ref_dfdv = ref.drag_terms(shape.triangles, share, x, v, wind, 0.8, lift, 0.7)
    assert_relative(force, ref_force, 1e-12, "drag force")
    assert_relative(-minus_dfdv, ref_dfdv, 1e-12, "drag df/dv")
    # exact where every face moves along its normal relative to the air
    normal = np.zeros_like(v)
    for ids in shape.triangles:
        face = np.cross(x[ids[1]] - x[ids[0]], x[ids[2]] - x[ids[0]])
        normal[ids] = wind + rng.uniform(0.5, 2.0) * face / np.linalg.norm(face)
    lift = 0.0  # the lift (at right angles to the motion) has no Jacobian
    share = np.ones(n)  # and the symmetric blocks are exact only for equal shares
    assert_relative(-run(normal)[1], finite_difference(lambda w: run(w)[0], normal), FD_RTOL, "drag df/dv vs FD")


# ----------------------------------------------------------------- rest state
def curved_grid(columns=9):
    """A grid bent into a quarter cylinder, with UVs stretched 3x along u and sheared."""
    mesh = grid(columns, columns, 1.0 / (columns - 1), plane="XZ")
    pos = mesh.vertex_pos.astype(np.float64)
    angle = pos[:, 0] * (np.pi / 2)
    bent = np.stack([np.sin(angle), 1.0 - np.cos(angle), pos[:, 2]], axis=1)
    uv = mesh.face_vertex_uv.astype(np.float64) @ np.array([[3.0, 0.0], [0.4, 1.0]])
    return bent, mesh.face_vertex_indices.reshape(-1, 3).astype(np.int32), uv.reshape(-1, 3, 2)


def test_rest_state_is_free_of_stress_whatever_the_uv_scale():
    pos, triangles, corner_uv = curved_grid()
    shape = build_rest_shape(pos, triangles, corner_uv)
    assert np.all(shape.tri_area > 0)
    for t in range(0, triangles.shape[0], 7):
        conditions = ref.triangle_conditions(pos, triangles[t], shape.tri_dinv[t], shape.tri_area[t])
        assert max(abs(c[0]) for c in conditions) < 1e-12
    np.testing.assert_allclose(dihedral_angles(pos, shape.hinges), shape.hinge_rest_angle, atol=0)
    force, _, _ = run_triangles(shape, pos, np.zeros_like(pos), exact=False)
    assert np.abs(force).max() < 1e-10


def test_warp_follows_the_uv_u_direction():
    """Stretching the cloth along the direction in which u grows shows up in C_u only."""
    pos, triangles, corner_uv = curved_grid()
    shape = build_rest_shape(pos, triangles, corner_uv)
    # u grows along the cylinder's arc (mesh x), with a shear from v; stretch 10% along z (v's axis)
    stretched = pos * np.array([1.0, 1.0, 1.1])
    for t in range(0, triangles.shape[0], 5):
        cu, cv, cs = ref.triangle_conditions(stretched, triangles[t], shape.tri_dinv[t], shape.tri_area[t])
        assert abs(cu[0]) < 1e-9 and cv[0] / shape.tri_area[t] == pytest.approx(0.1, abs=1e-9)
        assert abs(cs[0]) < 1e-9


def test_fabric_uvs_follow_the_fan_triangulation():
    fabric = grid_fabric(5)
    uvs = triangle_corner_uvs(fabric)
    expected = fabric.face_vertex_uv.reshape(-1, 3, 2)  # one triangle per face
    np.testing.assert_array_equal(uvs, expected)
    assert triangle_corner_uvs(fabric.replace(face_vertex_uv=np.zeros((0, 2), np.float32))) is None


def test_hinge_weight_gives_the_sheet_bending_energy():
    """A sheet rolled into a cylinder of curvature kappa across the triangles' diagonals
    stores D/2 kappa^2 per unit area (E = sum of k/2 theta^2, k = D |e|^2/(A_a + A_b))."""
    columns = 21
    mesh = grid(columns, columns, 1.0 / (columns - 1), plane="XZ")
    pos = mesh.vertex_pos.astype(np.float64)
    shape = build_rest_shape(pos, mesh.face_vertex_indices.reshape(-1, 3))
    radius = 2.0
    s = (pos[:, 0] - pos[:, 2]) / np.sqrt(2)
    t = (pos[:, 0] + pos[:, 2]) / np.sqrt(2)
    rolled = np.stack([radius * np.sin(s / radius), radius * (1 - np.cos(s / radius)), t], axis=1)
    modulus = 2e-3
    energy = ref.hinge_energy(rolled, shape.hinges, shape.hinge_rest_angle, modulus * shape.hinge_weight)
    assert energy == pytest.approx(modulus / 2 / radius**2 * 1.0, rel=0.01)


# ----------------------------------------------------------------- pattern and colouring
def test_pattern_slots_address_the_element_blocks():
    fabric = grid_fabric(6)
    shape = build_rest_shape(fabric.rest_pos, fabric.triangles)
    pattern = build_pattern(fabric.particle_count, shape.triangles, shape.hinges)
    rows = np.repeat(np.arange(fabric.particle_count), np.diff(pattern.row_offsets))
    for elements, slots in ((shape.triangles, pattern.triangle_slot), (shape.hinges, pattern.hinge_slot)):
        corners = elements.shape[1]
        a, b = np.divmod(np.arange(corners * corners), corners)
        np.testing.assert_array_equal(rows[slots], elements[:, a])
        np.testing.assert_array_equal(pattern.columns[slots], elements[:, b])
    np.testing.assert_array_equal(pattern.columns[pattern.diagonal_slot], np.arange(fabric.particle_count))
    assert np.all(np.diff(pattern.columns)[np.diff(rows) == 0] > 0)  # sorted, unique per row


@pytest.mark.parametrize("corners", [3, 4])
def test_colors_share_no_particle(corners):
    fabric = grid_fabric(12)
    shape = build_rest_shape(fabric.rest_pos, fabric.triangles)
    elements = shape.triangles if corners == 3 else shape.hinges
    order, offsets = color_elements(elements, fabric.particle_count)
    np.testing.assert_array_equal(np.sort(order), np.arange(elements.shape[0]))
    for k in range(offsets.shape[0] - 1):
        members = elements[order[offsets[k]:offsets[k + 1]]].reshape(-1)
        assert np.unique(members).size == members.size
    assert offsets.shape[0] - 1 <= 3 * corners * 2  # greedy stays near the valence


@pytest.mark.parametrize("corners", [2, 3, 4])
def test_greedy_colors_match_reference(corners):
    fabric = grid_fabric(9)
    shape = build_rest_shape(fabric.rest_pos, fabric.triangles)
    elements = {2: np.ascontiguousarray(shape.triangles[:, :2]), 3: shape.triangles, 4: shape.hinges}[corners]
    rng = np.random.default_rng(corners)
    elements = np.ascontiguousarray(elements[rng.permutation(elements.shape[0])])
    colors = np.empty(elements.shape[0], np.int64)
    count = greedy_colors(elements, fabric.particle_count, colors)
    expected, expected_count = ref_coloring.greedy_colors(elements, fabric.particle_count)
    np.testing.assert_array_equal(colors, expected)
    assert count == expected_count
