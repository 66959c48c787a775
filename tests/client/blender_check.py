# Imports a BVH exported by `voxcap export` with Blender's stock importer (headless) and writes what
# Blender made of it as JSON, for tests/client/blender_test.cpp to compare with joints.csv:
#   blender -b --factory-startup --python blender_check.py -- take.bvh out.json FRAME0 FRAME1 ...
# out.json: {"blender": version, "bones": [names], "action_frames" (keyframes per channel),
#            "action_range", "frame_start", "frame_end", "fps", "fps_base",
#            "frames": {"<k>": {"<bone>": [x, y, z], ...}}} — world positions of each bone's head (its
# joint) at take frame k (Blender frame frame_start + k), in Blender's world (metres, z up).
#
# Debian bookworm's Blender 3.4.1 ships a BVH importer that opens the file with mode 'rU', which its
# Python 3.11 rejects ("ValueError: invalid mode: 'rU'"); dropping the 'U' is all it takes.
import builtins
import json
import sys

import bpy

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str) and "U" in mode:
        mode = mode.replace("U", "")
    return _open(file, mode, *args, **kwargs)


builtins.open = _open_without_u

argv = sys.argv[sys.argv.index("--") + 1:]
bvh, out = argv[0], argv[1]
frames = [int(k) for k in argv[2:]]

# An empty scene, then the stock importer with its defaults (forward -Z, up Y, scale 1).
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.import_anim.bvh(filepath=bvh, update_scene_fps=True, update_scene_duration=True)
if result != {"FINISHED"}:
    raise SystemExit("import_anim.bvh: " + str(result))
scene = bpy.context.scene
arm = next(o for o in scene.objects if o.type == "ARMATURE")
action = arm.animation_data.action
report = {
    "action_frames": max(len(fc.keyframe_points) for fc in action.fcurves),
    "action_range": list(action.frame_range),
    "blender": bpy.app.version_string,
    "bones": [b.name for b in arm.data.bones],
    "frame_start": scene.frame_start,
    "frame_end": scene.frame_end,
    "fps": scene.render.fps,
    "fps_base": scene.render.fps_base,
    "frames": {},
}
for k in frames:
    scene.frame_set(scene.frame_start + k)
    mw = arm.matrix_world
    report["frames"][str(k)] = {pb.name: list(mw @ pb.head) for pb in arm.pose.bones}
with _open(out, "w") as f:
    json.dump(report, f)
print("blender_check: wrote", out)
