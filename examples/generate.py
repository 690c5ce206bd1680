"""Regenerate the bundled example garments (run from the repository root).

    python examples/generate.py

* ``skirt/skirt.usda``: an A-line skirt (quads, UVs with a seam, metres, Y up) with painted
  primvars ``pin`` (1 on the waistband) and ``maxdist`` (0 at the waist, 1 at the hem).
* ``cape/cape.obj``: a cape draped around the shoulders (quads, UVs), pinned along the
  neckline through the red vertex colour channel (``--pin-attr color_r``).
* ``skirt/walk.toml``: the skirt on a walking character proxy: a pelvis sphere and two
  tapered-capsule legs swinging on keyframed tracks, the skirt simulated in the hips' frame.
* ``shot/shot.usda``: a DCC-style shot: a low-poly humanoid (torso, hips, legs) skinned with
  UsdSkel and walking, and a skirt fitted to it in the bind pose (its waistband on the hips,
  clear of the hips and thighs below), marked ``clothtool:role = "cloth"`` with a painted
  waistband that attaches to the body; the solver and material settings that keep its
  strain to a few percent are in the stage (``SHOT_FREQUENCY``, ``SHOT_MATERIAL``).
* ``sheet/sheet.obj`` and ``sheet/swing.toml``: a 1 m square sheet (24 x 24 quads) pinned
  along its top edge, released 60 degrees from hanging: the integrator studies' test scene.

The files are committed; this script documents how they were made and rebuilds them
byte-for-byte.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def skirt_grid(columns: int = 48, rings: int = 20):
    """An A-line skirt: a cone frustum from the waist (y = 1.0 m) down to the hem (y = 0.45 m)."""
    waist_radius, hem_radius = 0.16, 0.42
    top, bottom = 1.0, 0.45
    pos, uv = [], []
    for j in range(rings):
        t = j / (rings - 1)
        radius = waist_radius + t * (hem_radius - waist_radius)
        y = top + t * (bottom - top)
        for i in range(columns + 1):  # column `columns` duplicates column 0: the UV seam
            angle = 2 * np.pi * i / columns
            pos.append((radius * np.sin(angle), y, radius * np.cos(angle)))
            uv.append((i / columns, 1 - t))
    pos = np.asarray(pos)
    faces = []
    width = columns + 1
    for j in range(rings - 1):
        for i in range(columns):
            a = j * width + i
            faces.append((a, a + width, a + width + 1, a + 1))  # outward-facing winding
    pin = np.array([1.0 if j == 0 else 0.0 for j in range(rings) for _ in range(width)])
    maxdist = np.array([j / (rings - 1) for j in range(rings) for _ in range(width)])
    return pos, np.asarray(uv), np.asarray(faces), pin, maxdist


def write_skirt_usda(path: Path) -> None:
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    pos, uv, faces, pin, maxdist = skirt_grid()
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/Skirt")
    stage.SetDefaultPrim(root.GetPrim())
    mesh = UsdGeom.Mesh.Define(stage, "/Skirt/Geo")
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in pos]))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([4] * len(faces)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for f in faces for i in f]))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    st = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray([Gf.Vec2f(*map(float, uv[i])) for f in faces for i in f]))
    for name, values in (("pin", pin), ("maxdist", maxdist)):
        primvar = primvars.CreatePrimvar(name, Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex)
        primvar.Set(Vt.FloatArray([float(v) for v in values]))
    path.write_text(stage.GetRootLayer().ExportToString())


def write_cape_obj(path: Path, columns: int = 32, rows: int = 28) -> None:
    """A cape hanging from the shoulders: the top row follows an arc around the neck."""
    lines = ["# clothtool example: a cape; red vertex colour = pin weight"]
    width = columns + 1
    for j in range(rows):
        t = j / (rows - 1)
        for i in range(width):
            s = i / columns
            angle = np.pi * (s - 0.5) * (1.0 - 0.6 * t)  # arc at the neck, opening towards the hem
            radius = 0.18 + 0.35 * t
            x = radius * np.sin(angle)
            z = -radius * np.cos(angle) * (1.0 - 0.5 * t) - 0.05
            y = 1.5 - 0.9 * t
            red = 1.0 if j == 0 else 0.0
            lines.append(f"v {x:.6f} {y:.6f} {z:.6f} {red:.1f} 0.0 0.0")
    for j in range(rows):
        for i in range(width):
            lines.append(f"vt {i / columns:.6f} {1 - j / (rows - 1):.6f}")
    for j in range(rows - 1):
        for i in range(columns):
            a = j * width + i + 1  # OBJ is 1-based
            quad = (a, a + 1, a + width + 1, a + width)
            lines.append("f " + " ".join(f"{v}/{v}" for v in quad))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


WALK_HEADER = """# Generated by examples/generate.py: the skirt on a walking character proxy.
# The hips walk forward at 1.2 m/s with a slight bob; the legs (tapered capsules hanging from
# the hip joints) swing +-25 degrees out of phase, one stride per second; the skirt is pinned
# at the waist and simulated in the hips' moving frame.
version = 1

[scene]
name = "skirt_walk"
fps = 24.0
frames = [1, 48]
meters_per_unit = 1.0
up_axis = "Y"

[solver]
preset = "production"

[output]
attributes = ["velocities", "stats", "colliders"]

[cloth.skirt]
mesh = "skirt.usda"
cook = { preset = "garment" }
material = "cotton"
track = "hips"

[collider.pelvis]
kind = "sphere"
center = [0.0, 0.9, 0.0]
radius = 0.13
track = "hips"
friction = 0.3

[collider.leg_left]
kind = "capsule"
start = [0.0, 0.0, 0.0]
end = [0.0, -0.85, 0.0]
radii = [0.075, 0.05]
track = "leg_left"
friction = 0.3

[collider.leg_right]
kind = "capsule"
start = [0.0, 0.0, 0.0]
end = [0.0, -0.85, 0.0]
radii = [0.075, 0.05]
track = "leg_right"
friction = 0.3
"""


def walk_tracks(first: int = 1, last: int = 49, step: int = 3, fps: float = 24.0) -> str:
    """Keyframes every ``step`` frames: hips translation; each leg's hip joint and swing."""
    lines = []
    frames = range(first, last + 1, step)

    def hips(frame):
        t = (frame - first) / fps
        return (0.0, 0.02 * np.sin(4 * np.pi * t), 1.2 * t)

    def key(frame, translate, euler=None):
        parts = [f"time = {frame}", "translate = [" + ", ".join(f"{v:.5f}" for v in translate) + "]"]
        if euler is not None:
            parts.append("rotate_euler = [" + ", ".join(f"{v:.4f}" for v in euler) + "]")
        return "  { " + ", ".join(parts) + " },"

    lines += ["", "[track.hips]", 'interpolation = "cubic"', "keys = ["]
    lines += [key(f, hips(f)) for f in frames] + ["]"]
    for name, side, phase in (("leg_left", -0.09, 0.0), ("leg_right", 0.09, np.pi)):
        lines += ["", f"[track.{name}]", 'interpolation = "cubic"', "keys = ["]
        for f in frames:
            t = (f - first) / fps
            x, y, z = hips(f)
            swing = 25.0 * np.sin(2 * np.pi * t + phase)
            lines.append(key(f, (x + side, y + 0.88, z), (swing, 0.0, 0.0)))
        lines.append("]")
    return "\n".join(lines) + "\n"


SWING = """# Generated by examples/generate.py: a 1 m sheet pinned along its top edge, released 60
# degrees from hanging (tilted about X), swinging under gravity. Smooth, with no contact and
# no buckling, so bakes at different settings can be compared point by point. Undamped and
# without air drag: "damping" means velocity damping to the position-based solver but
# material damping to the implicit and explicit ones, so only without it do all four
# integrators model the same physics.
version = 1

[scene]
name = "sheet_swing"
fps = 24.0
frames = [1, 25]

[solver]
preset = "production"

[cloth.sheet]
mesh = "sheet.obj"
cook = { pin_box = [-0.01, -0.01, -0.01, 1.01, 0.01, 0.01], tethers = "none" }
material = { preset = "cotton", damping = 0.0, drag_coefficient = 0.0, lift_coefficient = 0.0 }
rotate_euler = [60.0, 0.0, 0.0]
translate = [-0.5, 1.5, 0.0]
"""


def write_sheet_obj(path: Path, quads: int = 24) -> None:
    """A 1 m square in the XY plane hanging down from y = 0 (quads, UVs)."""
    lines = ["# clothtool example: a 1 m square sheet, row 0 at the top"]
    n = quads + 1
    for j in range(n):
        for i in range(n):
            lines.append(f"v {i / quads:.6f} {-j / quads:.6f} 0.000000")
    for j in range(n):
        for i in range(n):
            lines.append(f"vt {i / quads:.6f} {1 - j / quads:.6f}")
    for j in range(quads):
        for i in range(quads):
            a = j * n + i + 1
            quad = (a, a + n, a + n + 1, a + 1)
            lines.append("f " + " ".join(f"{v}/{v}" for v in quad))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


SHOT_FRAMES = (1, 48)
SHOT_FREQUENCY = 2400.0  # solver iterations per second
# cotton's shear stiffness raised (0.6 lets the skirt shear a sixth as the walk starts), and no
# velocity damping: the cloth is simulated in the world, where NvCloth-style damping drags a
# garment that walks at 1 m/s like a wind from the front
SHOT_MATERIAL = {"shearing:stiffness": 0.9, "damping": 0.0}
JOINTS = ["hips", "hips/spine", "hips/l_thigh", "hips/l_thigh/l_shin", "hips/r_thigh", "hips/r_thigh/r_shin"]
JOINT_WORLD = {  # bind pose: joint positions in the world (metres, Y up), no rotation
    "hips": (0.0, 0.92, 0.0), "hips/spine": (0.0, 1.12, 0.0),
    "hips/l_thigh": (0.09, 0.88, 0.0), "hips/l_thigh/l_shin": (0.09, 0.48, 0.0),
    "hips/r_thigh": (-0.09, 0.88, 0.0), "hips/r_thigh/r_shin": (-0.09, 0.48, 0.0),
}


# the body's tubes: ring heights (downwards) and half-widths along X and Z, metres
TORSO_Y = [1.45, 1.32, 1.18, 1.05, 0.95, 0.86, 0.78]
TORSO_RX = [0.15, 0.16, 0.14, 0.13, 0.15, 0.165, 0.12]
TORSO_RZ = [0.09, 0.10, 0.09, 0.085, 0.10, 0.105, 0.08]
LEG_X = 0.09  # each leg's centre, either side of the middle
LEG_Y = [0.90, 0.78, 0.62, 0.50, 0.46, 0.30, 0.14, 0.06]
LEG_RX = [0.075, 0.078, 0.064, 0.052, 0.05, 0.047, 0.038, 0.04]
LEG_RZ = [0.075, 0.078, 0.064, 0.052, 0.05, 0.047, 0.038, 0.05]
# the skirt's waistband: the torso's ring at y 0.95, which the hips joint alone moves (the
# spine's weight starts at 0.98), so the pinned ring rides a rigid part of the body and its
# edges keep their length; (y, half-width along X, half-depth along Z), metres
WAIST = (0.95, 0.15, 0.10)
# the hem: a little wider front to back than side to side, where the stride needs room
HEM = (0.45, 0.28, 0.38)
CLEARANCE = 0.02  # metres between the skirt's rest shape and the body below the waistband


def body_extent(y: float) -> tuple[float, float]:
    """The bind-pose body's half-width (X) and half-depth (Z) at height ``y``: the torso's
    rings and the legs' (linearly between rings), whichever reaches further."""
    rx = np.interp(-y, [-h for h in TORSO_Y], TORSO_RX, left=0.0, right=0.0)
    rz = np.interp(-y, [-h for h in TORSO_Y], TORSO_RZ, left=0.0, right=0.0)
    leg_rx = np.interp(-y, [-h for h in LEG_Y], LEG_RX, left=0.0, right=0.0)
    leg_rz = np.interp(-y, [-h for h in LEG_Y], LEG_RZ, left=0.0, right=0.0)
    return max(rx, LEG_X + leg_rx if leg_rx else 0.0), max(rz, leg_rz)


def _tube(center_x: float, heights, radii_x, radii_z, segments: int = 12):
    """Rings of an elliptical tube along Y, closed by a centre vertex at each end."""
    points = []
    for y, rx, rz in zip(heights, radii_x, radii_z):
        for k in range(segments):
            angle = 2 * np.pi * k / segments
            points.append((center_x + rx * np.sin(angle), y, rz * np.cos(angle)))
    top, bottom = len(points), len(points) + 1
    points += [(center_x, heights[0], 0.0), (center_x, heights[-1], 0.0)]
    faces = []
    for r in range(len(heights) - 1):
        for k in range(segments):
            a, b = r * segments + k, r * segments + (k + 1) % segments
            faces.append((a, b, b + segments, a + segments))  # outward (heights run downwards)
    last = (len(heights) - 1) * segments
    faces += [(top, (k + 1) % segments, k) for k in range(segments)]
    faces += [(bottom, last + k, last + (k + 1) % segments) for k in range(segments)]
    return np.asarray(points), faces


def fitted_skirt(columns: int = 36, rings: int = 14, ease: float = 0.012):
    """The shot's skirt, fitted to the humanoid: its waistband is the body's elliptical
    cross-section at ``WAIST`` grown by ``ease`` metres, so the pinned ring sits on the body (a
    round waistband hangs centimetres off the front and back, and the attachment's long normal
    offsets then stretch it as the body bends); below, the rings widen linearly towards the
    elliptical ``HEM``, and never come closer than ``CLEARANCE`` to the hips and thighs.
    Returns what ``skirt_grid`` returns."""
    y_waist, rx_waist, rz_waist = WAIST
    hem_y, hem_rx, hem_rz = HEM
    pos, uv = [], []
    for j in range(rings):
        t = j / (rings - 1)
        y = y_waist + t * (hem_y - y_waist)
        body_rx, body_rz = body_extent(y)
        rx = rx_waist + ease + t * (hem_rx - rx_waist - ease)
        rz = rz_waist + ease + t * (hem_rz - rz_waist - ease)
        if j > 0:  # below the waistband the skirt clears the hips and thighs
            rx, rz = max(rx, body_rx + CLEARANCE), max(rz, body_rz + CLEARANCE)
        for i in range(columns + 1):  # column `columns` duplicates column 0: the UV seam
            angle = 2 * np.pi * i / columns
            pos.append((rx * np.sin(angle), y, rz * np.cos(angle)))
            uv.append((i / columns, 1 - t))
    width = columns + 1
    faces = [(j * width + i, (j + 1) * width + i, (j + 1) * width + i + 1, j * width + i + 1)
             for j in range(rings - 1) for i in range(columns)]
    pin = np.array([1.0 if j == 0 else 0.0 for j in range(rings) for _ in range(width)])
    maxdist = np.array([j / (rings - 1) for j in range(rings) for _ in range(width)])
    return np.asarray(pos), np.asarray(uv), np.asarray(faces), pin, maxdist


def humanoid_body():
    """A low-poly body (torso with hips, two legs as closed tubes) and its skin weights:
    (points, faces, joint indices (v,2), joint weights (v,2))."""
    torso, torso_faces = _tube(0.0, TORSO_Y, TORSO_RX, TORSO_RZ)
    parts, faces, influences = [torso], list(torso_faces), []
    for y in torso[:, 1]:  # hips below the waist, spine above, blended over 0.98..1.12
        w = float(np.clip((y - 0.98) / 0.14, 0.0, 1.0))
        influences.append(((0, 1), (1.0 - w, w)))
    for x, thigh, shin in ((LEG_X, 2, 3), (-LEG_X, 4, 5)):
        leg, leg_faces = _tube(x, LEG_Y, LEG_RX, LEG_RZ)
        offset = sum(len(p) for p in parts)
        faces += [tuple(i + offset for i in f) for f in leg_faces]
        parts.append(leg)
        for y in leg[:, 1]:
            if y > 0.80:  # the top of the thigh blends into the hips
                w = float(np.clip((y - 0.80) / 0.12, 0.0, 1.0))
                influences.append(((0, thigh), (w, 1.0 - w)))
            else:  # the knee blends thigh and shin over 0.42..0.54
                w = float(np.clip((y - 0.42) / 0.12, 0.0, 1.0))
                influences.append(((thigh, shin), (w, 1.0 - w)))
    indices = np.array([i for i, _ in influences], np.int32)
    weights = np.array([w for _, w in influences], np.float32)
    return np.vstack(parts), faces, indices, weights


def walk_pose(frame: float, fps: float = 24.0):
    """Per joint (translation, quaternion w x y z) local transforms of the walk at ``frame``.
    The stride ramps up from the bind pose over the first half second (the skirt, modelled
    in the bind pose, starts settled), then one stride per second at 1 m/s."""
    t = (frame - SHOT_FRAMES[0]) / fps
    ramp = float(np.clip(t / 0.5, 0.0, 1.0))
    ramp = ramp * ramp * (3 - 2 * ramp)
    phase = 2 * np.pi * t
    swing = np.radians(28.0) * ramp * np.sin(phase)
    knee_l = np.radians(35.0) * ramp * max(0.0, np.sin(phase + 1.2))
    knee_r = np.radians(35.0) * ramp * max(0.0, np.sin(phase + 1.2 + np.pi))

    def about_x(angle):
        return (float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0)

    def about_y(angle):
        return (float(np.cos(angle / 2)), 0.0, float(np.sin(angle / 2)), 0.0)

    hips_at = np.array(JOINT_WORLD["hips"]) + [0.0, 0.015 * ramp * np.cos(2 * phase), 0.9 * t * ramp]
    parent = {"hips/spine": "hips", "hips/l_thigh": "hips", "hips/r_thigh": "hips",
              "hips/l_thigh/l_shin": "hips/l_thigh", "hips/r_thigh/r_shin": "hips/r_thigh"}
    local = {j: tuple(np.subtract(JOINT_WORLD[j], JOINT_WORLD[parent[j]])) for j in parent}
    return [
        (tuple(hips_at), about_y(np.radians(6.0) * ramp * np.sin(phase))),
        (local["hips/spine"], about_y(-np.radians(8.0) * ramp * np.sin(phase))),
        (local["hips/l_thigh"], about_x(-swing)),
        (local["hips/l_thigh/l_shin"], about_x(knee_l)),
        (local["hips/r_thigh"], about_x(swing)),
        (local["hips/r_thigh/r_shin"], about_x(knee_r)),
    ]


def write_walk_shot(path: Path) -> None:
    """A DCC-style shot: a UsdSkel-skinned humanoid walking, and the skirt modelled on it in
    the bind pose, marked as cloth with a painted waistband (primvar ``pin``)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdSkel, Vt

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetTimeCodesPerSecond(24.0)
    stage.SetFramesPerSecond(24.0)
    stage.SetStartTimeCode(SHOT_FRAMES[0])
    stage.SetEndTimeCode(SHOT_FRAMES[1])
    # 100 iterations a frame: the production preset's 12.5 leave the skirt on the walking body
    # stretched by a sixth
    stage.GetRootLayer().customLayerData = {"clothtool": {"solver": {"preset": "production", "frequency": SHOT_FREQUENCY}}}
    root = UsdGeom.Xform.Define(stage, "/Shot")
    stage.SetDefaultPrim(root.GetPrim())
    UsdSkel.Root.Define(stage, "/Shot/Character")
    skeleton = UsdSkel.Skeleton.Define(stage, "/Shot/Character/Skeleton")
    skeleton.CreateJointsAttr(JOINTS)
    skeleton.CreateBindTransformsAttr(Vt.Matrix4dArray(
        [Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(*JOINT_WORLD[j])) for j in JOINTS]))
    rest = walk_pose(SHOT_FRAMES[0])
    skeleton.CreateRestTransformsAttr(Vt.Matrix4dArray(
        [Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(*map(float, t))) for t, _ in rest]))
    anim = UsdSkel.Animation.Define(stage, "/Shot/Character/Skeleton/Walk")
    anim.CreateJointsAttr(JOINTS)
    anim.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1)] * len(JOINTS)))
    translations, rotations = anim.CreateTranslationsAttr(), anim.CreateRotationsAttr()
    for frame in range(SHOT_FRAMES[0], SHOT_FRAMES[1] + 1):
        pose = walk_pose(frame)
        translations.Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, t)) for t, _ in pose]), Usd.TimeCode(frame))
        rotations.Set(Vt.QuatfArray([Gf.Quatf(q[0], q[1], q[2], q[3]) for _, q in pose]), Usd.TimeCode(frame))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    points, faces, indices, weights = humanoid_body()
    body = UsdGeom.Mesh.Define(stage, "/Shot/Character/Body")
    body.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in points]))
    body.CreateFaceVertexCountsAttr(Vt.IntArray([len(f) for f in faces]))
    body.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for f in faces for i in f]))
    body.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    binding = UsdSkel.BindingAPI.Apply(body.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 2).Set(Vt.IntArray([int(i) for i in indices.ravel()]))
    binding.CreateJointWeightsPrimvar(False, 2).Set(Vt.FloatArray([float(w) for w in weights.ravel()]))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
    UsdPhysics.CollisionAPI.Apply(body.GetPrim())
    body.GetPrim().CreateAttribute("clothtool:thickness", Sdf.ValueTypeNames.Double).Set(0.005)

    pos, uv, quads, pin, _ = fitted_skirt(columns=36, rings=14)
    skirt = UsdGeom.Mesh.Define(stage, "/Shot/Skirt")
    skirt.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in pos]))
    skirt.CreateFaceVertexCountsAttr(Vt.IntArray([4] * len(quads)))
    skirt.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for f in quads for i in f]))
    skirt.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    primvars = UsdGeom.PrimvarsAPI(skirt)
    st = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray([Gf.Vec2f(*map(float, uv[i])) for f in quads for i in f]))
    primvars.CreatePrimvar("pin", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex).Set(
        Vt.FloatArray([float(v) for v in pin]))
    prim = skirt.GetPrim()
    prim.CreateAttribute("clothtool:role", Sdf.ValueTypeNames.String).Set("cloth")
    prim.CreateAttribute("clothtool:cook:preset", Sdf.ValueTypeNames.String).Set("garment")
    prim.CreateAttribute("clothtool:material", Sdf.ValueTypeNames.String).Set("cotton")
    for name, value in SHOT_MATERIAL.items():
        prim.CreateAttribute(f"clothtool:material:{name}", Sdf.ValueTypeNames.Double).Set(value)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(stage.GetRootLayer().ExportToString())


def main() -> None:
    write_skirt_usda(HERE / "skirt" / "skirt.usda")
    write_cape_obj(HERE / "cape" / "cape.obj")
    (HERE / "skirt" / "walk.toml").write_text(WALK_HEADER + walk_tracks())
    write_sheet_obj(HERE / "sheet" / "sheet.obj")
    (HERE / "sheet" / "swing.toml").write_text(SWING)
    write_walk_shot(HERE / "shot" / "shot.usda")


if __name__ == "__main__":
    main()
