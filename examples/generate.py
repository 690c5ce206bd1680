"""Regenerate the bundled example garments (run from the repository root).

    python examples/generate.py

* ``skirt/skirt.usda``: an A-line skirt (quads, UVs with a seam, metres, Y up) with painted
  primvars ``pin`` (1 on the waistband) and ``maxdist`` (0 at the waist, 1 at the hem).
* ``cape/cape.obj``: a cape draped around the shoulders (quads, UVs), pinned along the
  neckline through the red vertex colour channel (``--pin-attr color_r``).

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


def main() -> None:
    write_skirt_usda(HERE / "skirt" / "skirt.usda")
    write_cape_obj(HERE / "cape" / "cape.obj")


if __name__ == "__main__":
    main()
