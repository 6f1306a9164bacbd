"""isoloft.reconstruct(sections): drawn sections in any orientation from
Python (plane poses with polylines, in-plane or world points), through the
run path the CLI takes for a CSL file; touching labels as one partition;
bad input named by section and problem."""

import numpy as np
import pytest

import isoloft

RADIUS = 20.0
POINTS = 240  # per circle: chord error r (1 - cos(pi / 240)) = 1.7e-3 mm
CELLS = 48  # field3d's grid: coarser than the default 96, the properties checked hold at any
FIELD3D = {"resolution": CELLS}


def circle(radius, n=POINTS):
    a = 2 * np.pi * np.arange(n) / n
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)


def orthogonal_sphere_sections(world=False):
    """A sphere of RADIUS about (5, -3, 7) cut by the three axis planes
    through its centre; in-plane points, or the same points in world space."""
    centre = np.array([5.0, -3.0, 7.0])
    axes = [((1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, 1)), ((0, 0, 1), (1, 0, 0))]
    out = []
    for u, v in axes:
        pts = circle(RADIUS)
        if world:
            pts = centre + pts[:, :1] * np.array(u, float) + pts[:, 1:] * np.array(v, float)
        out.append({"origin": centre, "u": u, "v": v, "contours": [{"points": pts}]})
    return out


@pytest.mark.parametrize("world", [False, True])
def test_sphere_on_three_orthogonal_planes_is_one_closed_genus0_mesh(world):
    res = isoloft.reconstruct(orthogonal_sphere_sections(world), method="field3d", field3d=FIELD3D)
    assert len(res.objects) == 1
    rep = res.objects[0].report
    assert rep["closed"] and rep["manifold"] and rep["oriented"], rep
    assert rep["components"] == 1 and rep["euler_characteristic"] == 2, rep  # genus 0
    assert res.report["input"]["format"] == "sections" and res.report["input"]["planes"] == 3
    v = res.objects[0].vertices
    # The surface passes through the drawn circles: on each plane's circle the
    # nearest vertex lies within a grid cell (CELLS over the box and its margin).
    centre = np.array([5.0, -3.0, 7.0])
    cell = (2 * RADIUS * 1.2) / CELLS
    for u, v_ in [((1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, 1))]:
        ring = centre + circle(RADIUS, 36)[:, :1] * np.array(u, float) + circle(RADIUS, 36)[:, 1:] * np.array(v_, float)
        d = np.sqrt(((ring[:, None, :] - v[None, :, :]) ** 2).sum(-1)).min(axis=1)
        assert d.max() <= cell, d.max()


def test_in_plane_and_world_points_give_the_same_mesh():
    a = isoloft.reconstruct(orthogonal_sphere_sections(False), method="field3d", field3d=FIELD3D)
    b = isoloft.reconstruct(orthogonal_sphere_sections(True), method="field3d", field3d=FIELD3D)
    assert a.objects[0].vertices.shape == b.objects[0].vertices.shape
    # World points projected back onto the plane differ by rounding (1e-14 mm);
    # conjugate gradients stop at a relative residual of 1e-5, so the fields
    # may differ about that much of a cell: 1e-3 mm is 1/1000 of a cell here
    # (measured 5.7e-6 mm, float32 vertices).
    assert np.abs(a.objects[0].vertices - b.objects[0].vertices).max() < 1e-3


def half_disc(radius, side, n=POINTS // 2):
    """The half of a circle at x * side >= 0, its straight edge on x = 0
    ending exactly at (0, -radius) and (0, radius)."""
    a = np.pi * np.arange(n + 1) / n - np.pi / 2  # -90 .. 90 degrees
    pts = np.stack([side * radius * np.cos(a), radius * np.sin(a)], axis=1)
    pts[0], pts[-1] = (0.0, -radius), (0.0, radius)
    return pts


def test_touching_labels_share_their_boundary():
    """Two half-discs on three axial planes: each label's mesh closed and
    oriented, and the vertices of the shared face (near x = 0, away from its
    rim) the same points in both."""
    sections = []
    for z in (-10.0, 0.0, 10.0):
        r = np.sqrt(RADIUS**2 - z**2)
        sections.append({"origin": (0, 0, z), "u": (1, 0, 0), "v": (0, 1, 0),
                         "contours": [{"points": half_disc(r, -1), "label": 1}, {"points": half_disc(r, 1), "label": 2}]})
    res = isoloft.reconstruct(sections, method="field3d", field3d=FIELD3D)
    assert [o.report["roi"] for o in res.objects] == ["label1", "label2"]
    for o in res.objects:
        assert o.report["closed"] and o.report["oriented"] and o.report["components"] == 1, o.report
    cell = 2 * RADIUS * 1.2 / CELLS  # the grid's spacing, about: the shared face lies within it of x = 0
    face = [{tuple(p) for p in o.vertices if abs(p[0]) < 2 * cell and abs(p[1]) < 10 and abs(p[2]) < 5}
            for o in res.objects]
    assert len(face[0]) > 20 and face[0] == face[1], (len(face[0]), len(face[1]), len(face[0] ^ face[1]))


def test_field3d_over_the_memory_budget_is_refused_before_the_solve():
    """field3d's grid is estimated before it is made: 1024 cells per side
    (~1.1e9 nodes) is over the default 4 GiB, and a partition of two labels
    at the test's 48 cells over a 1 MiB budget; the error names the label
    and the grid."""
    with pytest.raises(isoloft.ParamError, match=r"max_memory: label 1 of sections \(field3d: a 1025x1025x1025 grid.* over the budget of 4 GiB"):
        isoloft.reconstruct(orthogonal_sphere_sections(), method="field3d", field3d={"resolution": 1024})
    sections = [{"origin": (0, 0, z), "u": (1, 0, 0), "v": (0, 1, 0),
                 "contours": [{"points": half_disc(RADIUS, -1), "label": 1}, {"points": half_disc(RADIUS, 1), "label": 2}]}
                for z in (-10.0, 0.0, 10.0)]
    with pytest.raises(isoloft.ParamError, match=r"max_memory: .*label \d of sections \(field3d: a \d+x\d+x\d+ grid.* over the budget of 1 MiB"):
        isoloft.reconstruct(sections, method="field3d", field3d=FIELD3D, max_memory="1M")


def test_column_methods_refuse_sections():
    with pytest.raises(isoloft.ParamError, match="field3d"):
        isoloft.reconstruct(orthogonal_sphere_sections(), method="isoloft")


@pytest.mark.parametrize("edit, where, problem", [
    (lambda s: s[1].update(v=(1, 1, 0)), r"sections\[1\]", "unit and orthogonal"),
    (lambda s: s[2].pop("u"), r"sections\[2\]", "no 'u'"),
    (lambda s: s[0].update(colour=1), r"sections\[0\]", "unknown key 'colour'"),
    (lambda s: s[0]["contours"][0].update(points=np.zeros((2, 2))), r"sections\[0\].contours\[0\].points", "at least 3"),
    (lambda s: s[1]["contours"][0].update(points=np.full((5, 2), np.nan)), r"sections\[1\].contours\[0\].points",
     "not finite"),
    (lambda s: s[0]["contours"][0].update(label=0), r"sections\[0\].contours\[0\].label", "0 is outside"),
    (lambda s: s[0]["contours"][0].update(points=np.ones((4, 4))), r"sections\[0\].contours\[0\].points", "N x 2"),
    (lambda s: s[0].update(origin=(0, 0)), r"sections\[0\].origin", "3 numbers"),
])
def test_bad_input_names_the_section_and_the_problem(edit, where, problem):
    s = orthogonal_sphere_sections()
    edit(s)
    with pytest.raises(isoloft.InputError, match=where + ".*" + problem):
        isoloft.reconstruct(s, method="field3d", field3d=FIELD3D)


def test_world_points_off_their_plane_are_refused():
    s = orthogonal_sphere_sections(world=True)
    s[1]["contours"][0]["points"] = s[1]["contours"][0]["points"] + np.array([0.5, 0, 0])  # plane 1 is x = 5
    with pytest.raises(isoloft.InputError, match=r"sections\[1\].contours\[0\].points.*off the section's plane"):
        isoloft.reconstruct(s, method="field3d", field3d=FIELD3D)


def test_read_options_are_refused_with_sections():
    with pytest.raises(isoloft.ParamError, match="z_spacing"):
        isoloft.reconstruct(orthogonal_sphere_sections(), method="field3d", z_spacing=2)
