#!/usr/bin/env python3
"""Convert a lightlearn glTF scene into a Mitsuba 3 scene, and render it with Mitsuba.

An independent cross-check of lightlearn's renderer: the same scene, the same conventions,
another renderer. `tests/mitsuba.rs` renders a Cornell box with both and compares.

Usage
    python3 scripts/mitsuba_scene.py SCENE.glb --width W --height H --spp N --out OUT.exr
        Renders with Mitsuba 3 (variant scalar_rgb) and writes a float32 RGB OpenEXR
        (or an 8-bit sRGB preview if OUT ends in .png). --seed S picks the sample pattern.
    python3 scripts/mitsuba_scene.py SCENE.glb --export-xml DIR [--width W ...]
        Writes DIR/scene.xml and DIR/meshes/*.ply; open it with `mitsuba DIR/scene.xml`
        (`-D spp=...`, `-D width=...`, `-D height=...` override the defaults written).
    Both options may be given together. The render itself loads the same XML (written to a
    temporary folder), so what --export-xml writes is exactly what was rendered.

Needs: Python 3, numpy, and `pip install mitsuba` (for rendering; --export-xml alone needs
only numpy). The glTF (.glb, or .gltf with data: or external buffers) is parsed here with the
standard library + numpy.

Conventions (those of lightlearn's README, "Scene conventions"; they define "the same image"):
- Geometry: every triangle primitive of the default scene (`scene`, else the first), node
  hierarchy flattened with the full node transforms (matrix or translation·rotation·scale).
  A mirroring transform (negative determinant) flips the winding back, so counter-clockwise
  stays the front face. Strips and fans are triangulated like lightlearn does; point and
  line primitives and degenerate (zero-area) triangles are dropped.
- Materials reflect on both sides (`twosided`). Textures are ignored here (lightlearn samples
  base-colour PNG textures): compare only untextured scenes.
  - metallicFactor 0 with KHR_materials_specular specularFactor 0 (what lightlearn's scene
    writer emits for plain materials): `diffuse`, reflectance = baseColorFactor.rgb clamped
    to [0, 1]. Exact.
  - metallicFactor 1: `roughconductor`, GGX, alpha = roughnessFactor², material "none"
    (Fresnel 1) × specular_reflectance = baseColorFactor.rgb. Exact for a white (1, 1, 1)
    base colour, where glTF's Schlick Fresnel is 1 too; a coloured metal reflects the base
    colour at all angles here but tends to white at grazing angles in glTF (warned).
    Mitsuba's shadowing is the separable Smith G1·G1, lightlearn's the height-correlated
    form: rough metals differ by up to a few percent at grazing angles.
  - Anything else (a dielectric with glTF's 4 % specular layer, partly metallic): has no
    Mitsuba equivalent; rendered as `diffuse` with a warning. Compare only exact scenes.
- Emission: radiance = emissiveFactor × KHR_materials_emissive_strength.emissiveStrength on
  an `area` emitter. Mitsuba's area emitters emit on the side of the geometric normal
  cross(p1 - p0, p2 - p0), i.e. from the counter-clockwise front face, as lightlearn does.
  The PLYs carry no vertex normals and load with face_normals=true, so shading uses the
  geometric normal too. A `doubleSided` emissive material also emits from the back: the mesh
  is added a second time with flipped winding, moved back along each face normal by 1e-5 ×
  the scene's bounding-box diagonal, so that a ray from either side meets the copy that
  emits towards it first (two coincident surfaces would make the hit ambiguous).
- KHR_lights_punctual point light: Mitsuba `point`, intensity = color × intensity (radiant
  intensity, W/sr). `range` is ignored, as in lightlearn.
- KHR_lights_punctual spot light: Mitsuba `spot` with cutoff_angle = outerConeAngle and
  beam_width = innerConeAngle. THE FALLOFF BETWEEN THE CONES DIFFERS: glTF/lightlearn use
  a squared linear ramp in cos θ, Mitsuba a linear ramp in the angle θ. Inside the inner cone
  and outside the outer cone both agree. Compare images only on scenes without spots.
- Directional lights and orthographic cameras: skipped with a warning (as in lightlearn).
- Camera: the first perspective camera in the node hierarchy (depth first, document order),
  looking down its local -Z with +Y up; yfov is the vertical field of view (fov_axis = y);
  the aspect ratio comes from the image size. Without one, the same default as lightlearn:
  45° vertical fov, looking at the bounds' centre from direction (0, 0.35, 1), distance
  radius / sin(22.5°).
- Film: box pixel filter (lightlearn box-filters), independent sampler, black background.
- Integrator, from --max-depth D (lightlearn's count of surface vertices):
  D = 1: `direct`: emission seen by the camera plus light reflected once (Mitsuba combines
  light and BSDF sampling with MIS, lightlearn samples lights only: same expected value,
  different noise). D ≥ 2: `path` with max_depth D + 1 (Mitsuba counts path segments: its
  max_depth 2 is direct light), Russian roulette at its default depth.
"""

import argparse
import base64
import json
import math
import os
import struct
import sys
import tempfile

import numpy as np

# ---------------------------------------------------------------------------------------------
# glTF reading


def read_gltf(path):
    """Returns (document, [buffer bytes])."""
    with open(path, "rb") as f:
        data = f.read()
    bin_chunk = None
    if data[:4] == b"glTF":
        version, length = struct.unpack_from("<II", data, 4)
        if version != 2:
            raise ValueError(f"{path}: GLB version {version}, expected 2")
        off, doc = 12, None
        while off + 8 <= min(length, len(data)):
            clen, ctype = struct.unpack_from("<II", data, off)
            chunk = data[off + 8 : off + 8 + clen]
            if ctype == 0x4E4F534A:  # 'JSON'
                doc = json.loads(chunk.decode("utf-8"))
            elif ctype == 0x004E4942 and bin_chunk is None:  # 'BIN\0'
                bin_chunk = chunk
            off += 8 + clen
        if doc is None:
            raise ValueError(f"{path}: GLB without a JSON chunk")
    else:
        doc = json.loads(data.decode("utf-8"))
    buffers = []
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is None:
            if bin_chunk is None:
                raise ValueError(f"{path}: buffer {i} refers to a GLB BIN chunk, but there is none")
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            from urllib.parse import unquote

            with open(os.path.join(os.path.dirname(path), unquote(uri)), "rb") as f:
                buffers.append(f.read())
    return doc, buffers


_COMPONENT = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def read_accessor(doc, buffers, index):
    """Accessor `index` as a (count, components) numpy array (float64 or int64)."""
    acc = doc["accessors"][index]
    if "sparse" in acc:
        raise ValueError(f"accessor {index}: sparse accessors are not supported")
    dtype = np.dtype(_COMPONENT[acc["componentType"]])
    ncomp = _NCOMP[acc["type"]]
    count = acc["count"]
    if "bufferView" not in acc:
        return np.zeros((count, ncomp))
    view = doc["bufferViews"][acc["bufferView"]]
    buf = buffers[view["buffer"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    elem = dtype.itemsize * ncomp
    stride = view.get("byteStride", elem)
    if count == 0:
        return np.zeros((0, ncomp), dtype)
    raw = np.frombuffer(buf, dtype=np.uint8, count=stride * (count - 1) + elem, offset=start)
    rows = np.lib.stride_tricks.as_strided(raw, shape=(count, elem), strides=(stride, 1))
    return np.ascontiguousarray(rows).view(dtype).reshape(count, ncomp)


def node_matrix(node):
    """Local 4x4 transform of a node (column vectors: p' = M p)."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    t = np.array(node.get("translation", [0.0, 0.0, 0.0]), dtype=np.float64)
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    s = np.array(node.get("scale", [1.0, 1.0, 1.0]), dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


def triangulate(mode, idx):
    """Index triples of a primitive (same rules as lightlearn's loader)."""
    idx = np.asarray(idx, dtype=np.int64)
    if mode == 4:
        return idx[: len(idx) // 3 * 3].reshape(-1, 3)
    if mode == 5:  # strip: every other triangle reversed to keep the winding
        tris = [
            (idx[i - 2], idx[i - 1], idx[i]) if i % 2 == 0 else (idx[i - 1], idx[i - 2], idx[i])
            for i in range(2, len(idx))
        ]
        return np.array(tris, dtype=np.int64).reshape(-1, 3)
    if mode == 6:  # fan
        tris = [(idx[0], idx[i - 1], idx[i]) for i in range(2, len(idx))]
        return np.array(tris, dtype=np.int64).reshape(-1, 3)
    return np.zeros((0, 3), dtype=np.int64)


def warn(msg):
    print(f"mitsuba_scene.py: warning: {msg}", file=sys.stderr)


def load_scene(path):
    """The scene as plain data: meshes (world-space triangles + material), lights, camera."""
    doc, buffers = read_gltf(path)
    scenes = doc.get("scenes", [])
    if not scenes:
        raise ValueError(f"{path}: no scene")
    roots = scenes[doc.get("scene", 0)].get("nodes", [])
    nodes = doc.get("nodes", [])
    lights_def = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])

    materials = {}  # glTF material index (None = default) -> dict

    def material(i):
        if i not in materials:
            m = doc["materials"][i] if i is not None else {}
            pbr = m.get("pbrMetallicRoughness", {})
            base = np.clip(np.array(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3], float), 0, 1)
            strength = (
                m.get("extensions", {})
                .get("KHR_materials_emissive_strength", {})
                .get("emissiveStrength", 1.0)
            )
            emission = np.array(m.get("emissiveFactor", [0, 0, 0]), float) * strength
            if "baseColorTexture" in pbr or "emissiveTexture" in m:
                warn(f"material {i} has textures; only the factors are used")
            metallic = float(pbr.get("metallicFactor", 1.0))
            roughness = float(pbr.get("roughnessFactor", 1.0))
            specular = (
                m.get("extensions", {})
                .get("KHR_materials_specular", {})
                .get("specularFactor", 1.0)
            )
            if metallic == 1.0:
                kind = "metal"
                if not np.all(base == 1.0):
                    warn(f"material {i} is a coloured metal: Mitsuba's conductor has no Schlick Fresnel, grazing angles differ")
            elif metallic == 0.0 and specular == 0.0:
                kind = "diffuse"
            else:
                kind = "diffuse"
                warn(f"material {i} (metallic {metallic}, specular {specular}) has a glTF dielectric specular layer with no Mitsuba equivalent; rendered as diffuse")
            materials[i] = {
                "id": f"mat{len(materials)}",
                "name": m.get("name", ""),
                "albedo": base,
                "kind": kind,
                "alpha": max(roughness * roughness, 1e-3),
                "emission": emission,
                "double_sided": bool(m.get("doubleSided", False)),
            }
        return materials[i]

    meshes, points, spots, camera = [], [], [], None
    stack = [(n, np.eye(4)) for n in reversed(roots)]
    while stack:
        ni, parent = stack.pop()
        node = nodes[ni]
        world = parent @ node_matrix(node)
        if "mesh" in node:
            mesh = doc["meshes"][node["mesh"]]
            flip = np.linalg.det(world[:3, :3]) < 0
            for pi, prim in enumerate(mesh["primitives"]):
                mode = prim.get("mode", 4)
                if mode not in (4, 5, 6):
                    warn(f"mesh {node['mesh']} primitive {pi} has mode {mode}, not triangles; skipped")
                    continue
                pos = read_accessor(doc, buffers, prim["attributes"]["POSITION"]).astype(np.float64)
                if "indices" in prim:
                    idx = read_accessor(doc, buffers, prim["indices"]).ravel().astype(np.int64)
                else:
                    idx = np.arange(len(pos))
                tris = triangulate(mode, idx)
                if flip:
                    tris = tris[:, [0, 2, 1]]
                wpos = pos @ world[:3, :3].T + world[:3, 3]
                # lightlearn computes in float32: drop the triangles it drops as degenerate.
                p32 = wpos.astype(np.float32)
                cr = np.cross(p32[tris[:, 1]] - p32[tris[:, 0]], p32[tris[:, 2]] - p32[tris[:, 0]])
                tris = tris[np.einsum("ij,ij->i", cr, cr) > 0]
                if len(tris) == 0:
                    continue
                meshes.append(
                    {
                        "name": f"{mesh.get('name', 'mesh')}_{node['mesh']}_{pi}",
                        "positions": wpos,
                        "faces": tris,
                        "material": material(prim.get("material")),
                    }
                )
        li = node.get("extensions", {}).get("KHR_lights_punctual", {}).get("light")
        if li is not None:
            light = lights_def[li]
            intensity = np.array(light.get("color", [1, 1, 1]), float) * light.get("intensity", 1.0)
            position = world[:3, 3].copy()
            direction = -world[:3, 2]
            kind = light.get("type")
            if intensity.max() <= 0:
                warn(f"light {li} has zero intensity; skipped")
            elif kind == "point":
                points.append({"position": position, "intensity": intensity})
            elif kind == "spot":
                spot = light.get("spot", {})
                outer = min(max(spot.get("outerConeAngle", math.pi / 4), 0.0), math.pi / 2)
                inner = min(max(spot.get("innerConeAngle", 0.0), 0.0), outer)
                spots.append(
                    {
                        "position": position,
                        "direction": direction / np.linalg.norm(direction),
                        "intensity": intensity,
                        "inner": inner,
                        "outer": outer,
                    }
                )
            else:
                warn(f"light {li} is {kind}, which lightlearn does not support; skipped")
        if camera is None and "camera" in node:
            cam = doc["cameras"][node["camera"]]
            if cam.get("type") == "perspective":
                camera = {
                    "position": world[:3, 3].copy(),
                    "forward": -world[:3, 2] / np.linalg.norm(world[:3, 2]),
                    "up": world[:3, 1] / np.linalg.norm(world[:3, 1]),
                    "yfov": cam["perspective"]["yfov"],
                }
            else:
                warn(f"camera {node['camera']} is not perspective; ignored")
        stack.extend((c, world) for c in reversed(node.get("children", [])))

    if not meshes:
        raise ValueError(f"{path}: no triangles")
    pts = [m["positions"][m["faces"].ravel()] for m in meshes]
    pts += [l["position"][None, :] for l in points + spots]
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    if camera is None:  # lightlearn's Camera::framing
        centre = 0.5 * (lo + hi)
        radius = max(0.5 * np.linalg.norm(hi - lo), 1e-3)
        yfov = math.radians(45.0)
        d = np.array([0.0, 0.35, 1.0])
        d /= np.linalg.norm(d)
        camera = {
            "position": centre + d * radius / math.sin(0.5 * yfov),
            "forward": -d,
            "up": np.array([0.0, 1.0, 0.0]),
            "yfov": yfov,
        }
    return {"meshes": meshes, "points": points, "spots": spots, "camera": camera, "bounds": (lo, hi)}


# ---------------------------------------------------------------------------------------------
# Mitsuba XML + PLY


def write_ply(path, positions, faces):
    """Binary little-endian PLY, positions only (no normals: Mitsuba uses face normals)."""
    v = np.ascontiguousarray(positions, dtype="<f4")
    f = np.empty(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    f["n"] = 3
    f["i"] = faces
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(v.tobytes())
        out.write(f.tobytes())


def fmt(v):
    return ", ".join(f"{float(x):.9g}" for x in np.ravel(v))


def lookat_xml(origin, target, up, indent):
    return (
        f'{indent}<transform name="to_world">\n'
        f'{indent}    <lookat origin="{fmt(origin)}" target="{fmt(target)}" up="{fmt(up)}"/>\n'
        f"{indent}</transform>\n"
    )


def any_perpendicular(d):
    a = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return np.cross(d, a)


def export_xml(scene, out_dir, width, height, spp, seed=0, max_depth=1):
    """Writes out_dir/scene.xml and out_dir/meshes/*.ply; returns the XML path."""
    mesh_dir = os.path.join(out_dir, "meshes")
    os.makedirs(mesh_dir, exist_ok=True)
    lo, hi = scene["bounds"]
    diag = float(np.linalg.norm(hi - lo)) or 1.0
    cam = scene["camera"]
    dist = float(np.linalg.norm(0.5 * (lo + hi) - cam["position"]))
    x = [
        '<?xml version="1.0" encoding="utf-8"?>\n',
        "<!-- Written by lightlearn scripts/mitsuba_scene.py; conventions in its header. -->\n",
        '<scene version="3.0.0">\n',
        f'    <default name="spp" value="{spp}"/>\n',
        f'    <default name="width" value="{width}"/>\n',
        f'    <default name="height" value="{height}"/>\n',
        f'    <default name="seed" value="{seed}"/>\n\n',
        ('    <integrator type="direct"/>\n\n' if max_depth == 1 else
         f'    <integrator type="path">\n        <integer name="max_depth" value="{max_depth + 1}"/>\n'
         '    </integrator>\n\n'),
        '    <sensor type="perspective">\n',
        '        <string name="fov_axis" value="y"/>\n',
        f'        <float name="fov" value="{math.degrees(cam["yfov"]):.9g}"/>\n',
        f'        <float name="near_clip" value="{1e-5 * diag:.9g}"/>\n',
        f'        <float name="far_clip" value="{10 * (diag + dist):.9g}"/>\n',
        lookat_xml(cam["position"], cam["position"] + cam["forward"], cam["up"], " " * 8),
        '        <sampler type="independent">\n',
        '            <integer name="sample_count" value="$spp"/>\n',
        '            <integer name="seed" value="$seed"/>\n',
        "        </sampler>\n",
        '        <film type="hdrfilm">\n',
        '            <integer name="width" value="$width"/>\n',
        '            <integer name="height" value="$height"/>\n',
        '            <string name="pixel_format" value="rgb"/>\n',
        '            <string name="component_format" value="float32"/>\n',
        '            <rfilter type="box"/>\n',
        "        </film>\n",
        "    </sensor>\n\n",
    ]
    mats = {}
    for m in scene["meshes"]:
        mats[m["material"]["id"]] = m["material"]
    for mid, m in mats.items():
        x.append(f'    <!-- {m["name"].replace("--", "- -")} -->\n')
        x.append(f'    <bsdf type="twosided" id="{mid}">\n')
        if m["kind"] == "metal":
            # lightlearn clamps alpha at 1e-3 (shaders/shared/bsdf.glsl MIN_ALPHA).
            x.append('        <bsdf type="roughconductor">\n')
            x.append('            <string name="distribution" value="ggx"/>\n')
            x.append(f'            <float name="alpha" value="{m["alpha"]:.9g}"/>\n')
            x.append('            <string name="material" value="none"/>\n')
            x.append(f'            <rgb name="specular_reflectance" value="{fmt(m["albedo"])}"/>\n')
        else:
            x.append('        <bsdf type="diffuse">\n')
            x.append(f'            <rgb name="reflectance" value="{fmt(m["albedo"])}"/>\n')
        x.append("        </bsdf>\n    </bsdf>\n")
    x.append("\n")

    def shape(fname, mat, emission):
        s = f'    <shape type="ply">\n        <string name="filename" value="meshes/{fname}"/>\n'
        s += '        <boolean name="face_normals" value="true"/>\n'
        s += f'        <ref id="{mat["id"]}"/>\n'
        if emission is not None:
            s += '        <emitter type="area">\n'
            s += f'            <rgb name="radiance" value="{fmt(emission)}"/>\n'
            s += "        </emitter>\n"
        return s + "    </shape>\n"

    for k, m in enumerate(scene["meshes"]):
        mat = m["material"]
        safe = "".join(c if c.isalnum() or c in "_-" else "_" for c in m["name"])
        fname = f"{k:04d}_{safe}.ply"
        write_ply(os.path.join(mesh_dir, fname), m["positions"], m["faces"])
        emits = mat["emission"].max() > 0
        x.append(shape(fname, mat, mat["emission"] if emits else None))
        if emits and mat["double_sided"]:
            # Back copy: flipped winding, unshared vertices moved back along each face normal.
            p = m["positions"][m["faces"]]  # (n, 3, 3)
            n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            p = p[:, [0, 2, 1]] - 1e-5 * diag * n[:, None, :]
            bname = f"{k:04d}_{safe}_back.ply"
            write_ply(os.path.join(mesh_dir, bname), p.reshape(-1, 3), np.arange(3 * len(p)).reshape(-1, 3))
            x.append(shape(bname, mat, mat["emission"]))
    for l in scene["points"]:
        x.append('    <emitter type="point">\n')
        x.append(f'        <point name="position" value="{fmt(l["position"])}"/>\n')
        x.append(f'        <rgb name="intensity" value="{fmt(l["intensity"])}"/>\n')
        x.append("    </emitter>\n")
    for l in scene["spots"]:
        # Mitsuba's spot points down its local +Z; falloff differs from glTF (see header).
        outer = math.degrees(l["outer"])
        inner = min(math.degrees(l["inner"]), outer * (1 - 1e-4))
        x.append('    <emitter type="spot">\n')
        x.append(f'        <rgb name="intensity" value="{fmt(l["intensity"])}"/>\n')
        x.append(f'        <float name="cutoff_angle" value="{outer:.9g}"/>\n')
        x.append(f'        <float name="beam_width" value="{inner:.9g}"/>\n')
        x.append(
            lookat_xml(
                l["position"], l["position"] + l["direction"], any_perpendicular(l["direction"]), " " * 8
            )
        )
        x.append("    </emitter>\n")
    x.append("</scene>\n")
    path = os.path.join(out_dir, "scene.xml")
    with open(path, "w") as f:
        f.write("".join(x))
    return path


# ---------------------------------------------------------------------------------------------
# Rendering


def render(xml_path, out, width, height, spp, seed):
    try:
        import mitsuba as mi
    except ImportError:
        sys.exit("mitsuba_scene.py: the mitsuba Python package is not installed (pip install mitsuba)")
    mi.set_variant("scalar_rgb")
    scene = mi.load_file(xml_path, spp=str(spp), width=str(width), height=str(height), seed=str(seed))
    img = np.array(mi.render(scene, seed=seed, spp=spp), dtype=np.float32)
    if img.shape != (height, width, 3):
        raise RuntimeError(f"unexpected image shape {img.shape}")
    if out.lower().endswith(".png"):
        bmp = mi.Bitmap(img).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True
        )
    else:
        bmp = mi.Bitmap(img)
    tmp = out + ".part" + os.path.splitext(out)[1]
    bmp.write(tmp)
    os.replace(tmp, out)


def main():
    ap = argparse.ArgumentParser(
        description="Convert a lightlearn glTF scene to Mitsuba 3 and render it."
    )
    ap.add_argument("scene", help="SCENE.glb or SCENE.gltf")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-depth", type=int, default=1,
                    help="surface vertices of a path as lightlearn counts them (1: direct light)")
    ap.add_argument("--out", help="render to this file: .exr (float32 RGB) or .png (sRGB preview)")
    ap.add_argument("--export-xml", metavar="DIR", help="write DIR/scene.xml and DIR/meshes/*.ply")
    a = ap.parse_args()
    if not a.out and not a.export_xml:
        ap.error("give --out OUT.exr (render) and/or --export-xml DIR")
    if min(a.width, a.height, a.spp, a.max_depth) < 1:
        ap.error("--width, --height, --spp and --max-depth must be at least 1")
    try:
        scene = load_scene(a.scene)
        if a.export_xml:
            export_xml(scene, a.export_xml, a.width, a.height, a.spp, a.seed, a.max_depth)
        if a.out:
            with tempfile.TemporaryDirectory(prefix="mitsuba_scene_") as tmp:
                xml = export_xml(scene, tmp, a.width, a.height, a.spp, a.seed, a.max_depth)
                render(xml, a.out, a.width, a.height, a.spp, a.seed)
    except (OSError, ValueError, KeyError, IndexError, RuntimeError, struct.error) as e:
        sys.exit(f"mitsuba_scene.py: error: {a.scene}: {type(e).__name__}: {e}")


if __name__ == "__main__":
    main()
