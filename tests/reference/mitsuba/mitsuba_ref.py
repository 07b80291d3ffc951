#!/usr/bin/env python3
"""Mitsuba 3 reference of the lumiwall Cornell box fixture (Y only, llvm_ad_mono).

Usage: DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
  venv/bin/python mitsuba_ref.py SCENE.toml SPP NPASS OUT.npy
Writes OUT.npy with shape (NPASS, H, W): Y per pass (independent seeds), cd/m².
Reads geometry/materials/camera from the fixture (cornell.toml + cornell.obj).
"""
import os, sys, tempfile, time, tomllib
import numpy as np
import mitsuba as mi
mi.set_variant("llvm_ad_mono")


def build(toml_path, move=None, max_depth=64):
    """The Mitsuba scene of a lumiwall fixture TOML + OBJ (one shape per OBJ object,
    written to a temporary folder), and its camera. `move(object, vertex)` places a
    vertex (file units) where an animation frame has it (animation_table.py);
    `max_depth` 3 keeps direct light and one bounce (voxel_gi_table.py)."""
    fix = os.path.dirname(os.path.abspath(toml_path))
    cfg = tomllib.load(open(toml_path, "rb"))
    unit = cfg["unit_m"]
    # split the OBJ into one file per object (v/f with per-object vertex numbering)
    objs, name, allv = {}, None, []
    for line in open(f"{fix}/{cfg['geometry']}"):
        t = line.split()
        if not t: continue
        if t[0] == "o": name = t[1]; objs[name] = []
        elif t[0] == "v": allv.append([float(x) for x in t[1:4]])
        elif t[0] == "f": objs[name].append([allv[int(i.split('/')[0]) - 1] for i in t[1:]])

    def mat_of(obj):
        return cfg.get("objects", {}).get(obj, cfg["default_material"])

    tmp = tempfile.mkdtemp(prefix="lumiwall-mitsuba-")
    scene = {"type": "scene",
             "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": 64}}
    for obj, faces in [(o, f) for o, f in objs.items() if f]:
        p = f"{tmp}/{os.path.basename(toml_path)}.{obj}.obj"
        with open(p, "w") as f:
            k = 1
            for face in faces:
                for v in face:
                    v = move(obj, v) if move else v
                    f.write("v %.9g %.9g %.9g\n" % tuple(x * unit for x in v))
                f.write("f " + " ".join(str(k + i) for i in range(len(face))) + "\n"); k += len(face)
        m = cfg["materials"][mat_of(obj)]
        rho = m["reflectance_xyz"][1] if "reflectance_xyz" in m else m["reflectance_y"]
        sh = {"type": "obj", "filename": p, "face_normals": True,
              "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": rho}}}
        if m.get("emission_cd_m2"):
            sh["emitter"] = {"type": "area", "radiance": {"type": "spectrum", "value": m["emission_cd_m2"]}}
        scene[obj] = sh
    for k, light in enumerate(cfg.get("lights", [])):
        if light.get("type", "point") != "point" or "intensity_cd" not in light:
            raise SystemExit("mitsuba_ref.py builds isotropic point lights given by intensity_cd only")
        scene[f"lamp_{k}"] = {"type": "point", "position": [x * unit for x in light["position"]],
                              "intensity": {"type": "spectrum", "value": light["intensity_cd"]}}
    c = cfg["camera"]
    scene["sensor"] = {"type": "perspective", "fov_axis": "y", "fov": c["vfov_deg"],
        "near_clip": 1e-3, "far_clip": 1e3,
        "to_world": mi.ScalarTransform4f().look_at(origin=[x * unit for x in c["position"]],
            target=[x * unit for x in c["look_at"]], up=c["up"]),
        "film": {"type": "hdrfilm", "width": c["width"], "height": c["height"],
                 "rfilter": {"type": "box"}, "pixel_format": "luminance"},
        "sampler": {"type": "independent", "sample_count": 1}}
    return mi.load_dict(scene)


def render_y(sc, spp, seed):
    """One pass: Y in cd/m² as an (H, W) array."""
    img = np.array(mi.render(sc, spp=spp, seed=seed))
    return img.reshape(img.shape[0], img.shape[1], -1)[..., 0]


def main():
    toml_path, spp, npass, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    sc = build(toml_path)
    imgs = []
    for s in range(npass):
        t = time.time()
        imgs.append(render_y(sc, spp, 1000 + s))
        print(f"pass {s}: {spp} spp, {time.time() - t:.1f} s", flush=True)
    np.save(out, np.stack(imgs))


if __name__ == "__main__":
    main()
