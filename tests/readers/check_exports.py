#!/usr/bin/env python3
"""Reads densepack exports back with real readers and checks them against the packing JSON.

Usage: check_exports.py KIND PACKING.json FILE [options]
       check_exports.py --batch CHECKS.tsv   (one check per line: NAME, KIND, PACKING.json,
                                              FILE, options, tab-separated; all are run, the
                                              failures named, exit 1 if any failed)
  gmsh  FILE.msh  [--shrink S] [--interface T] [--labels particle] [--tolerance 0.02]
        meshio reads the mesh; volumes per physical group (sum of tetrahedron volumes: per
        kind, or per particle with --labels particle) must match the exact volumes computed
        here from the packing within the tolerance; the container's faces are physical
        surfaces of the exact areas; on periodic axes the nodes of opposite faces must
        coincide after translation.
  vtk   FILE.vtu   meshio reads it (binary, zlib); points, radii, semi-axes, orientations,
                   half axes and shape tensors equal the packing's (ellipsoid and cylinder
                   values recomputed here from the quaternions and half axes); the container's
                   surface in FILE.container.vtu has the container's bounds and exact area.
  csv   FILE.csv   numpy reads it; rows equal the packing's particles (spheres).
  xyzd  FILE.xyzd  numpy reads the little-endian doubles; rows (x, y, z, d) equal the
                   packing's centres and diameters bit for bit.
  lammps FILE.data numpy reads the Atoms section; rows (id, type, d, density, x, y, z) equal
                   the packing's, the header counts and box bounds the container's.
  vti   FILE.vti FILE.npy   the VTK Python package reads the image data; its origin, spacing
                   and extent equal the .npy sidecar's and its cell array, reordered from
                   x fastest, equals the .npy image.
  abaqus FILE.inp FILE.npy  meshio reads the Abaqus file; one C3D8R (hexahedron) of positive
                   volume per voxel inside the container, element set sizes equal the label
                   counts of the .npy image of the same grid, face node sets lie on their
                   faces and XMIN/XMAX (…) list partner nodes in the same order.
  npy   FILE.npy   numpy loads it; the labels equal a brute-force numpy voxelisation of the
  raw   FILE.raw   packing (shape/dtype from the FILE.json sidecar for raw), and the voxel
                   packing fraction equals the sidecar's and the exact one within the
                   resolution bound.
Spheres, ellipsoids and cylinders are checked; exact volumes come from the packing JSON
(4/3 pi r^3, 4/3 pi a b c, pi r^2 2|l|).
Exit status 0 when every check passes; a failed check raises.
"""
import json
import math
import sys
import traceback

import numpy as np


def load_packing(path, spheres_only=True):
    with open(path) as f:
        p = json.load(f)
    spheres = [q for q in p["particles"] if q["type"] == "sphere"]
    if spheres_only:
        assert len(spheres) == len(p["particles"]), "only spheres are checked here"
    centres = np.array([q["center"] for q in spheres], dtype=float).reshape(-1, 3)
    radii = np.array([q["radius"] for q in spheres], dtype=float)
    return p, centres, radii


def rotation(q):
    """Rotation matrix of the unit quaternion [w, x, y, z] (body -> world)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def particle_volume(q, scale=1.0):
    """Exact volume of a particle record, its lengths scaled by `scale`."""
    if q["type"] == "sphere":
        return 4.0 / 3.0 * math.pi * (scale * q["radius"]) ** 3
    if q["type"] == "ellipsoid":
        a, b, c = (scale * x for x in q["semi_axes"])
        return 4.0 / 3.0 * math.pi * a * b * c
    assert q["type"] == "cylinder", q["type"]
    return math.pi * (scale * q["radius"]) ** 2 * 2.0 * scale * float(np.linalg.norm(q["half_axis"]))


def inside(q, d):
    """Whether the offsets d (..., 3) from the particle's centre lie inside particle q."""
    if q["type"] == "sphere":
        return np.einsum("...k,...k->...", d, d) <= q["radius"] ** 2
    if q["type"] == "ellipsoid":
        body = d @ rotation(q["orientation"])          # R^T d for each offset
        return level_ellipsoid(q, body) <= 1.0
    l = np.array(q["half_axis"], dtype=float)
    length = float(np.linalg.norm(l))
    t = d @ (l / length)
    radial2 = np.einsum("...k,...k->...", d, d) - t * t
    return (np.abs(t) <= length) & (radial2 <= q["radius"] ** 2)


def level_ellipsoid(q, body):
    return sum((body[..., k] / q["semi_axes"][k]) ** 2 for k in range(3))


def near_surface(q, d, tol=1e-9):
    """Offsets within a relative 1e-9 of the particle's surface (either label is right)."""
    if q["type"] == "sphere":
        return np.abs(np.sqrt(np.einsum("...k,...k->...", d, d)) / q["radius"] - 1) < tol
    if q["type"] == "ellipsoid":
        return np.abs(level_ellipsoid(q, d @ rotation(q["orientation"])) - 1) < tol
    l = np.array(q["half_axis"], dtype=float)
    length = float(np.linalg.norm(l))
    t = d @ (l / length)
    radial = np.sqrt(np.maximum(np.einsum("...k,...k->...", d, d) - t * t, 0))
    return (np.abs(np.abs(t) / length - 1) < tol) | (np.abs(radial / q["radius"] - 1) < tol)


def container_volume(c):
    if c["type"] == "box":
        return float(np.prod(np.array(c["max"]) - np.array(c["min"])))
    return math.pi * c["radius"] ** 2 * c["height"]


def option(args, name, default):
    if name in args:
        return float(args[args.index(name) + 1])
    return default


def linear_tet_volumes(pts, t):
    a, b, c, d = (pts[t[:, k]] for k in range(4))
    return np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6.0


def quadratic_tet_volumes(pts, t):
    """Volumes of curved 10-node tetrahedra: the integral of det J of the isoparametric
    quadratic map over the reference tetrahedron. J is linear in the reference coordinates, so
    det J is a cubic, integrated exactly by a collapsed 4x4x4 Gauss-Legendre rule. meshio
    stores the edge nodes in VTK order (edges 01, 12, 02, 03, 13, 23); checked here
    geometrically: almost every edge node must lie closest to its own edge's midpoint (a few
    strongly curved elements at thin shells may not)."""
    vert = pts[t[:, :4]]                      # (n, 4, 3)
    emid = pts[t[:, 4:]]                      # (n, 6, 3)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    edge_mid = np.stack([(vert[:, i] + vert[:, j]) / 2 for i, j in edges], axis=1)
    dist = np.linalg.norm(emid[:, :, None, :] - edge_mid[:, None, :, :], axis=3)
    agree = np.mean(np.all(np.argmin(dist, axis=2) == np.arange(6), axis=1))
    assert agree > 0.99, f"edge-node order: only {agree:.2%} of the elements match VTK order"
    g, w = np.polynomial.legendre.leggauss(4)
    g, w = (g + 1) / 2, w / 2
    dL = np.array([[-1, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    total = np.zeros(len(t))
    for u, wu in zip(g, w):
        for v, wv in zip(g, w):
            for s, ws in zip(g, w):
                xi, eta, zeta = u, v * (1 - u), s * (1 - u) * (1 - v)
                jac_collapse = (1 - u) ** 2 * (1 - v)
                L = np.array([1 - xi - eta - zeta, xi, eta, zeta])
                # dx/dxi = sum over shape functions of x_node * grad N.
                J = np.zeros((len(t), 3, 3))
                for i in range(4):
                    J += np.einsum("nc,k->nck", vert[:, i], (4 * L[i] - 1) * dL[i])
                for e, (i, j) in enumerate(edges):
                    J += np.einsum("nc,k->nck", emid[:, e], 4 * (L[j] * dL[i] + L[i] * dL[j]))
                total += wu * wv * ws * jac_collapse * np.linalg.det(J)
    return np.abs(total)


def check_gmsh(packing_path, mesh_path, args):
    import meshio

    p, centres, radii = load_packing(packing_path, spheres_only=False)
    shrink = option(args, "--shrink", 0.0)
    shell = option(args, "--interface", 0.0)
    assert shell == 0 or len(radii) == len(p["particles"]), "shells are checked for spheres only"
    tol = option(args, "--tolerance", 0.02)
    mesh = meshio.read(mesh_path)
    groups = {name: int(tag) for name, (tag, dim) in
              ((n, v[:2]) for n, v in mesh.field_data.items()) if dim == 3}
    # The particles' physical volumes: one per particle with --labels particle, else one per
    # kind present ("aggregates" when there is one kind).
    by_particle = "--labels" in args and args[args.index("--labels") + 1] == "particle"
    kind_names = {"sphere": "spheres", "ellipsoid": "ellipsoids", "cylinder": "cylinders"}
    kinds = {q["type"] for q in p["particles"]}
    def group_of(i, q):
        if by_particle:
            return f"particle_{i}"
        return "aggregates" if len(kinds) == 1 else kind_names[q["type"]]
    r = radii * (1.0 - shrink)
    expected = {}
    for i, q in enumerate(p["particles"]):
        g = group_of(i, q)
        expected[g] = expected.get(g, 0.0) + particle_volume(q, 1.0 - shrink)
    aggregates = sum(expected.values())
    interface = float(np.sum(4.0 / 3.0 * math.pi * ((r + shell) ** 3 - r ** 3))) if shell > 0 else 0.0
    total = container_volume(p["container"])
    expected["matrix"] = total - aggregates - interface
    if shell > 0:
        expected["interface"] = interface
    assert set(groups) == set(expected), f"physical volumes {sorted(groups)}, expected {sorted(expected)}"
    if by_particle:
        for name, tag in groups.items():
            if name.startswith("particle_"):
                assert tag == 1000 + int(name[len("particle_"):]), f"{name} has tag {tag}"
    volumes = {name: 0.0 for name in groups}
    pts = mesh.points
    tets = 0
    faces = {name: int(tag) for name, (tag, dim) in
             ((n, v[:2]) for n, v in mesh.field_data.items()) if dim == 2}
    areas = {name: 0.0 for name in faces}
    for block, phys in zip(mesh.cells, mesh.cell_data["gmsh:physical"]):
        if block.type in ("triangle", "triangle6"):
            # Corner nodes only: exact for the planar faces, a polygon for curved ones.
            t = block.data[:, :3]
            a = 0.5 * np.linalg.norm(np.cross(pts[t[:, 1]] - pts[t[:, 0]], pts[t[:, 2]] - pts[t[:, 0]]), axis=1)
            for name, tag in faces.items():
                areas[name] += float(a[phys == tag].sum())
            continue
        if block.type == "tetra":
            vol = linear_tet_volumes(pts, block.data)
        elif block.type == "tetra10":
            vol = quadratic_tet_volumes(pts, block.data)
        else:
            continue
        tets += len(block.data)
        for name, tag in groups.items():
            volumes[name] += float(vol[phys == tag].sum())
    assert tets > 0, "no tetrahedra in the mesh"
    for name, v in expected.items():
        rel = volumes[name] / v - 1.0
        if not name.startswith("particle_"):
            print(f"gmsh: {name}: mesh volume {volumes[name]:.6g}, exact {v:.6g}, relative {rel:+.3%}")
        assert abs(rel) <= tol, f"{name}: mesh volume off by {rel:+.3%} (tolerance {tol:.0%})"
    if by_particle:
        print(f"gmsh: {len(expected) - 1 - (shell > 0)} per-particle volumes within {tol:.0%}")
    # The container's faces: exact areas (planes), or within the tolerance (a cylinder's
    # curved side and its discs, approximated by the corner nodes' polygons).
    c = p["container"]
    if c["type"] == "box":
        e = np.array(c["max"], dtype=float) - np.array(c["min"], dtype=float)
        face_area = {f"{'xyz'[k]}{side}": float(e[(k + 1) % 3] * e[(k + 2) % 3])
                     for k in range(3) for side in ("min", "max")}
        face_tol = 1e-9
    else:
        disc = math.pi * c["radius"] ** 2
        face_area = {"bottom": disc, "top": disc, "side": 2.0 * math.pi * c["radius"] * c["height"]}
        face_tol = tol
    assert set(faces) == set(face_area), f"physical surfaces {sorted(faces)}, expected {sorted(face_area)}"
    for name, a in face_area.items():
        rel = areas[name] / a - 1.0
        assert abs(rel) <= face_tol, f"surface {name}: area {areas[name]:.6g}, exact {a:.6g} ({rel:+.3%})"
    print(f"gmsh: container faces {', '.join(sorted(faces))}: areas within {face_tol:g}")
    c = p["container"]
    if c["type"] == "box":
        # The exporter may translate a periodic box (a symmetry): take the faces from the mesh.
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        assert np.allclose(hi - lo, np.array(c["max"]) - np.array(c["min"]), rtol=1e-9)
        scale = float(np.max(hi - lo))
        for k, periodic in enumerate(c["periodic"]):
            if not periodic:
                continue
            low = pts[np.abs(pts[:, k] - lo[k]) < 1e-9 * scale]
            high = pts[np.abs(pts[:, k] - hi[k]) < 1e-9 * scale].copy()
            high[:, k] -= hi[k] - lo[k]
            assert len(low) == len(high) > 0, f"axis {k}: {len(low)} vs {len(high)} face nodes"
            key = lambda a: a[np.lexsort(np.round(a / (1e-7 * scale)).T[::-1])]
            gap = np.max(np.abs(key(low) - key(high)))
            assert gap < 1e-7 * scale, f"axis {k}: face nodes differ by {gap}"
            print(f"gmsh: axis {k} periodic: {len(low)} face nodes match")
    print(f"gmsh: ok ({len(pts)} nodes, {tets} tetrahedra)")


def check_vtk(packing_path, path):
    import meshio

    p, _, _ = load_packing(packing_path, spheres_only=False)
    particles = p["particles"]
    mesh = meshio.read(path)
    pd = mesh.point_data
    for name in ("radius", "semi_axes", "orientation", "shape_tensor", "half_axis", "shape"):
        assert name in pd, f"point array {name} missing: {sorted(pd)}"
    assert np.array_equal(mesh.points, np.array([q["center"] for q in particles], dtype=float))
    tensors = pd["shape_tensor"].reshape(-1, 3, 3)
    shapes = {"sphere": 1, "ellipsoid": 2, "cylinder": 3}
    for i, q in enumerate(particles):
        radius, semi, quat, half, shape = (pd[n][i] for n in
                                           ("radius", "semi_axes", "orientation", "half_axis", "shape"))
        assert int(np.ravel(shape)[0]) == shapes[q["type"]], (i, shape)
        if q["type"] == "sphere":
            r = q["radius"]
            assert float(np.ravel(radius)[0]) == r and np.array_equal(semi, [r, r, r])
            assert np.array_equal(quat, [1.0, 0, 0, 0]) and np.array_equal(half, [0.0, 0, 0])
            assert np.array_equal(tensors[i], r * np.eye(3))
        elif q["type"] == "ellipsoid":
            # The JSON values verbatim (full-precision floats survive the ASCII round trip).
            assert np.array_equal(semi, q["semi_axes"]), (semi, q["semi_axes"])
            assert np.array_equal(quat, q["orientation"]), (quat, q["orientation"])
            assert float(np.ravel(radius)[0]) == max(q["semi_axes"])
            assert np.array_equal(half, [0.0, 0, 0])
            rot = rotation(q["orientation"])
            expected = rot @ np.diag(q["semi_axes"]) @ rot.T
            assert np.allclose(tensors[i], expected, rtol=0, atol=1e-12 * max(q["semi_axes"]))
        else:
            l = np.array(q["half_axis"], dtype=float)
            length = float(np.linalg.norm(l))
            assert np.array_equal(half, l), (half, l)
            assert float(np.ravel(radius)[0]) == q["radius"]
            assert np.allclose(semi, [q["radius"], q["radius"], length], rtol=1e-15, atol=0)
            # The orientation turns the body z axis onto the half axis.
            rot = rotation(quat)
            assert abs(np.linalg.norm(quat) - 1) < 1e-12
            assert np.allclose(rot @ [0, 0, 1.0], l / length, atol=1e-12), (rot @ [0, 0, 1], l)
            expected = rot @ np.diag([q["radius"], q["radius"], length]) @ rot.T
            assert np.allclose(tensors[i], expected, rtol=0, atol=1e-12 * length)
    assert sum(len(b.data) for b in mesh.cells if b.type == "vertex") == len(particles)
    kinds = sorted({q["type"] for q in particles})
    print(f"vtk: ok ({len(particles)} particles: {', '.join(kinds)})")
    check_vtk_container(p["container"], path[: -len(".vtu")] + ".container.vtu")


def check_vtk_container(c, path):
    """The container's surface beside the particles' .vtu: its bounds are the container's
    and its polygons' area that of the box, or of the cylinder drawn as a prism over the
    regular 64-gon inscribed in its circle (exact formulas for both)."""
    import meshio

    mesh = meshio.read(path)
    pts = mesh.points
    area = 0.0
    for block in mesh.cells:
        assert block.type in ("quad", "triangle"), block.type
        for cell in block.data:
            v = pts[cell]
            for k in range(1, len(cell) - 1):  # fan triangulation of a planar convex polygon
                area += 0.5 * float(np.linalg.norm(np.cross(v[k] - v[0], v[k + 1] - v[0])))
    if c["type"] == "box":
        lo, hi = np.array(c["min"], dtype=float), np.array(c["max"], dtype=float)
        assert np.array_equal(pts.min(axis=0), lo) and np.array_equal(pts.max(axis=0), hi)
        e = hi - lo
        expected = 2.0 * float(e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
    else:
        r, h, k = c["radius"], c["height"], 64
        expected = k * 2.0 * r * math.sin(math.pi / k) * h + 2.0 * k * 0.5 * r * r * math.sin(2.0 * math.pi / k)
        z = pts[:, 2]
        assert abs(z.min() - c["base_center"][2]) < 1e-12 * h and abs(z.max() - c["base_center"][2] - h) < 1e-12 * h
    assert abs(area / expected - 1.0) < 1e-12, f"container area {area}, expected {expected}"
    print(f"vtk container: ok ({c['type']}, {sum(len(b.data) for b in mesh.cells)} polygons, area {area:.6g})")


def check_csv(packing_path, path):
    _, centres, radii = load_packing(packing_path)
    with open(path) as f:
        header = f.readline().strip()
    assert header == "x,y,z,r", header
    table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    assert np.array_equal(table[:, :3], centres) and np.array_equal(table[:, 3], radii)
    print(f"csv: ok ({len(radii)} rows)")


def check_xyzd(packing_path, path):
    _, centres, radii = load_packing(packing_path)
    table = np.fromfile(path, dtype="<f8").reshape(-1, 4)
    assert np.array_equal(table[:, :3], centres) and np.array_equal(table[:, 3], 2 * radii)
    print(f"xyzd: ok ({len(radii)} spheres)")


def check_lammps(packing_path, path):
    p, centres, radii = load_packing(packing_path)
    with open(path) as f:
        lines = f.read().split("\n")
    assert lines[0].startswith("LAMMPS data file"), lines[0]
    header = {}
    start = None
    for n, line in enumerate(lines[1:], 1):
        words = line.split("#")[0].split()
        if line.startswith("Atoms"):
            assert line.split("#")[1].strip() == "sphere", line
            start = n + 2
            break
        if words[-2:] in (["xlo", "xhi"], ["ylo", "yhi"], ["zlo", "zhi"]):
            header[words[-2]] = (float(words[0]), float(words[1]))
        elif words:
            header[" ".join(words[1:])] = int(words[0])
    assert header["atoms"] == len(radii) and header["atom types"] == 1, header
    c = p["container"]
    if c["type"] == "box":
        lo, hi = c["min"], c["max"]
    else:  # the cylinder's bounding box
        b, r = c["base_center"], c["radius"]
        lo, hi = [b[0] - r, b[1] - r, b[2]], [b[0] + r, b[1] + r, b[2] + c["height"]]
    for k, axis in enumerate("xyz"):
        assert header[axis + "lo"] == (lo[k], hi[k]), (axis, header[axis + "lo"])
    atoms = np.loadtxt(lines[start:start + len(radii)], ndmin=2)
    assert np.array_equal(atoms[:, 0], np.arange(1, len(radii) + 1))
    assert np.all(atoms[:, 1] == 1) and np.all(atoms[:, 3] == 1)
    assert np.array_equal(atoms[:, 2], 2 * radii) and np.array_equal(atoms[:, 4:7], centres)
    print(f"lammps: ok ({len(radii)} atoms, box {lo} .. {hi})")


def load_npy(path):
    with open(path + ".json") as f:
        return np.load(path), json.load(f)


def check_vti(path, npy_path):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    image, meta = load_npy(npy_path)
    reader = vtk.vtkXMLImageDataReader()
    reader.SetFileName(path)
    reader.Update()
    data = reader.GetOutput()
    nx, ny, nz = meta["shape"]
    assert data.GetDimensions() == (nx + 1, ny + 1, nz + 1), data.GetDimensions()
    assert np.allclose(data.GetOrigin(), meta["origin"], rtol=1e-15, atol=0)
    assert np.allclose(data.GetSpacing(), meta["spacing"], rtol=1e-15, atol=0)
    cells = data.GetCellData()
    assert cells.GetNumberOfArrays() == 1
    array = vtk_to_numpy(cells.GetArray(0))
    assert array.dtype == image.dtype, (array.dtype, image.dtype)
    assert np.array_equal(array.reshape(nz, ny, nx).transpose(2, 1, 0), image)
    print(f"vti: ok ({cells.GetArrayName(0)}, {image.dtype}, shape {image.shape}, equals the .npy)")


def check_abaqus(packing_path, path, npy_path):
    import meshio
    p, _, _ = load_packing(packing_path, spheres_only=False)
    image, meta = load_npy(npy_path)
    mesh = meshio.read(path, file_format="abaqus")
    particle_labels = meta["dtype"] == "uint32"
    outside = 2 ** 32 - 1 if particle_labels else 255
    inside = image != outside
    hexes = np.concatenate([b.data for b in mesh.cells if b.type == "hexahedron"])
    assert sum(len(b.data) for b in mesh.cells) == len(hexes) == np.count_nonzero(inside)
    # Positive volume in Abaqus node order: (n1 - n0) x (n3 - n0) . (n4 - n0) > 0.
    pts = mesh.points
    e = [pts[hexes[:, m]] - pts[hexes[:, 0]] for m in (1, 3, 4)]
    volume = np.einsum("ij,ij->i", np.cross(e[0], e[1]), e[2])
    assert np.allclose(volume, np.prod(meta["spacing"]), rtol=1e-9), (volume.min(), volume.max())
    sets = {name.upper(): sum(len(a) for a in arrays) for name, arrays in mesh.cell_sets.items()}
    if particle_labels:
        phase = np.zeros(image.shape, dtype=np.int64)
        for i, q in enumerate(p["particles"]):
            phase[image == i + 1] = PHASES[q["type"]]
            assert sets.get(f"PARTICLE_{i + 1}", 0) == np.count_nonzero(image == i + 1), i
    else:
        phase = image.astype(np.int64)
    for name, label in [("MATRIX", 0)] + list(PHASES.items()):
        expected = np.count_nonzero((phase == label) & inside)
        assert sets.get(name.upper(), 0) == expected, (name, sets.get(name.upper()), expected)
    nsets = {name.upper(): idx for name, idx in mesh.point_sets.items()}
    lo = np.array(meta["origin"])
    length = np.array(meta["shape"]) * np.array(meta["spacing"])
    axes = range(3) if p["container"]["type"] == "box" else [2]
    for k in axes:
        low, high = pts[nsets["XYZ"[k] + "MIN"]], pts[nsets["XYZ"[k] + "MAX"]]
        assert len(low) == len(high) > 0
        assert np.allclose(low[:, k], lo[k], rtol=0, atol=1e-12 * length[k])
        shifted = low.copy()
        shifted[:, k] += length[k]
        assert np.allclose(shifted, high, rtol=0, atol=1e-9 * length[k]), "XYZ"[k]
    print(f"abaqus: ok ({len(pts)} nodes, {len(hexes)} C3D8R, element sets "
          f"{sorted(n for n in sets if not n.startswith('PARTICLE_'))} + "
          f"{sum(n.startswith('PARTICLE_') for n in sets)} particle sets, face node sets "
          f"{sorted(nsets)})")


# Phase labels of the shapes (`--labels phase`); partial volumes count every solid voxel.
PHASES = {"sphere": 1, "ellipsoid": 2, "cylinder": 3}


def brute_force_labels(p, shape, spacing, origin, particle_labels, ambiguous=None):
    """Voxel-centre labels computed independently with numpy broadcasting (minimum image on
    periodic axes: every particle here is shorter than half the box). Voxels whose centre is
    within 1e-9 of a non-spherical surface are marked in `ambiguous` (rounding may go either
    way between this computation and the exporter's)."""
    c = p["container"]
    periodic = c.get("periodic", [False] * 3)
    axes = [origin[k] + (np.arange(shape[k]) + 0.5) * spacing[k] for k in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    labels = np.zeros(shape, dtype=np.int64)
    length = [shape[k] * spacing[k] for k in range(3)]
    for i, q in enumerate(p["particles"]):
        ctr = q["center"]
        d = np.zeros(shape + (3,))
        for k, grid in enumerate((X, Y, Z)):
            d[..., k] = grid - ctr[k]
            if periodic[k]:
                d[..., k] -= length[k] * np.round(d[..., k] / length[k])
        labels[inside(q, d)] = i + 1 if particle_labels else PHASES[q["type"]]
        if ambiguous is not None and q["type"] != "sphere":
            ambiguous |= near_surface(q, d)
    if c["type"] == "cylinder":
        b = c["base_center"]
        out = (X - b[0]) ** 2 + (Y - b[1]) ** 2 > c["radius"] ** 2
        labels[out] = 2 ** 32 - 1 if particle_labels else 255
    return labels


def exact_fraction(p):
    return sum(particle_volume(q) for q in p["particles"]) / container_volume(p["container"])


def check_partial_volume(p, image, meta):
    """Solid fractions from s^3 sample points per voxel, recomputed by brute force: the sample
    grid is a voxel grid s times finer, labelled here and averaged over each s^3 block."""
    s = int(meta["labels"]["samples_per_axis"])
    shape = tuple(meta["shape"])
    fine = brute_force_labels(p, tuple(n * s for n in shape),
                              [h / s for h in meta["spacing"]], meta["origin"], False)
    solid = ((fine > 0) & (fine != 255)).reshape(shape[0], s, shape[1], s, shape[2], s).mean(axis=(1, 3, 5))
    if p["container"]["type"] == "cylinder":
        centre_labels = brute_force_labels(p, shape, meta["spacing"], meta["origin"], False)
        solid[centre_labels == 255] = -1.0
    gap = float(np.max(np.abs(image.astype(np.float64) - solid)))
    assert gap < 1e-6, f"partial volumes differ from the numpy recomputation by {gap}"
    phi = exact_fraction(p)
    phi_vox = float(image[image > 0].astype(np.float64).sum()) * float(np.prod(meta["spacing"])) \
        / container_volume(p["container"])
    assert abs(phi_vox - meta["packing_fraction_voxels"]) < 1e-9
    assert abs(phi_vox - phi) <= meta["resolution_bound"], (phi_vox, phi, meta["resolution_bound"])
    print(f"partial volume: ok ({shape}, {s}^3 samples, φ exact {phi:.5f}, voxels {phi_vox:.5f})")


def check_voxels(packing_path, path, raw):
    p, _, _ = load_packing(packing_path, spheres_only=False)
    with open(path + ".json") as f:
        meta = json.load(f)
    shape = tuple(meta["shape"])
    if raw:
        image = np.fromfile(path, dtype=np.dtype(meta["numpy_descr"])).reshape(shape)
    else:
        image = np.load(path)
        assert image.shape == shape and image.dtype == np.dtype(meta["numpy_descr"])
    if meta["dtype"] == "float32":
        return check_partial_volume(p, image, meta)
    particle_labels = meta["dtype"] == "uint32"
    if not particle_labels:
        for name, label in PHASES.items():
            assert meta["labels"][str(label)] == name, meta["labels"]
    ambiguous = np.zeros(shape, dtype=bool)
    expected = brute_force_labels(p, shape, meta["spacing"], meta["origin"], particle_labels,
                                  ambiguous)
    differ = image.astype(np.int64) != expected
    # Centres exactly on a sphere surface could go either way in floating point; none expected.
    mismatch = int(np.count_nonzero(differ & ~ambiguous))
    assert mismatch == 0, f"{mismatch} voxels differ from the numpy voxelisation"
    outside = 2 ** 32 - 1 if particle_labels else 255
    solid = np.count_nonzero((image != 0) & (image != outside))
    phi_vox = solid * float(np.prod(meta["spacing"])) / container_volume(p["container"])
    phi = exact_fraction(p)
    assert abs(phi_vox - meta["packing_fraction_voxels"]) < 1e-12
    assert abs(phi - meta["packing_fraction_exact"]) < 1e-12
    assert abs(phi_vox - phi) <= meta["resolution_bound"], (phi_vox, phi, meta["resolution_bound"])
    print(f"{'raw' if raw else 'npy'}: ok ({shape}, φ exact {phi:.5f}, voxels {phi_vox:.5f}, "
          f"bound {meta['resolution_bound']:.2e}, {int(np.count_nonzero(differ))} surface voxels either way)")


def check(kind, packing_path, path, rest):
    if kind == "gmsh":
        check_gmsh(packing_path, path, rest)
    elif kind == "vtk":
        check_vtk(packing_path, path)
    elif kind == "csv":
        check_csv(packing_path, path)
    elif kind == "xyzd":
        check_xyzd(packing_path, path)
    elif kind == "lammps":
        check_lammps(packing_path, path)
    elif kind == "vti":
        check_vti(path, rest[0])
    elif kind == "abaqus":
        check_abaqus(packing_path, path, rest[0])
    elif kind in ("npy", "raw"):
        check_voxels(packing_path, path, kind == "raw")
    else:
        raise ValueError(f"unknown kind {kind}")


def batch(checks_path):
    """Runs every check of the file in this one process (numpy, meshio and vtk are imported
    once) and returns the names of those that failed."""
    with open(checks_path) as f:
        checks = [line.rstrip("\n").split("\t") for line in f if line.strip()]
    failed = []
    for name, kind, packing_path, path, *rest in checks:
        try:
            check(kind, packing_path, path, rest)
        except Exception:
            traceback.print_exc()
            print(f"FAILED: {name}", file=sys.stderr, flush=True)
            failed.append(name)
    print(f"exports: {len(checks) - len(failed)} passed, {len(failed)} failed")
    return failed


def main():
    if sys.argv[1] == "--batch":
        sys.exit(1 if batch(sys.argv[2]) else 0)
    kind, packing_path, path, *rest = sys.argv[1:]
    check(kind, packing_path, path, rest)


if __name__ == "__main__":
    main()
