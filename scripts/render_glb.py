# Renders a ScanCam .glb in Blender the way a user who opens it there sees it: the glTF
# importer, the texture on the surfaces (Workbench, texture colour, flat light), seen from the
# camera's own position and direction in the calibration. A development check of the glTF
# export (issue 6), not a product dependency.
#
# Usage: blender -b --python scripts/render_glb.py -- MODEL.glb CALIB.json OUT.png [FOV_DEG [AZIMUTH_DEG]]
# Without AZIMUTH_DEG the view is the camera's own; with it, the view is level (scan frame z up)
# from the camera's centre towards that azimuth (degrees from the scan frame's x axis), which
# suits an omnidirectional camera whose axis points at the ceiling.
import json
import math
import sys

import bpy
import numpy
from mathutils import Matrix, Vector

args = sys.argv[sys.argv.index("--") + 1:]
glb, calib, out = args[0], args[1], args[2]
fov_deg = float(args[3]) if len(args) > 3 else 100.0
azimuth_deg = float(args[4]) if len(args) > 4 else None

# Debian bookworm's Blender 3.4.1 glTF importer still uses numpy.bool, which bookworm's
# numpy 1.24 removed; restore the alias (it was the builtin bool).
if not hasattr(numpy, "bool"):
    numpy.bool = bool

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
if not meshes:
    sys.exit("render_glb: no mesh imported from " + glb)
faces = sum(len(o.data.polygons) for o in meshes)
uv = sum(len(o.data.uv_layers) for o in meshes)
images = [i.name for i in bpy.data.images]
print(f"render_glb: {len(meshes)} mesh object(s), {faces} faces, {uv} UV layer(s), images {images}")

# T_cam_scan (X_cam = R X_scan + t). Blender's glTF importer turns glTF's y-up back into
# Blender's z-up, and ScanCam's .glb node rotation maps the scan frame's z-up onto glTF's
# y-up, so Blender coordinates are scan coordinates.
T = json.load(open(calib))["T_cam_scan"]
R = Matrix([T[0][:3], T[1][:3], T[2][:3]])
t = Vector([T[0][3], T[1][3], T[2][3]])
Rt = R.transposed()
centre = -(Rt @ t)
right, down, forward = Rt @ Vector((1, 0, 0)), Rt @ Vector((0, 1, 0)), Rt @ Vector((0, 0, 1))
if azimuth_deg is not None:
    a = math.radians(azimuth_deg)
    forward = Vector((math.cos(a), math.sin(a), 0.0))
    down = Vector((0.0, 0.0, -1.0))
    right = forward.cross(Vector((0.0, 0.0, 1.0)))
# A Blender camera looks along its local -z with +y up.
rot = Matrix((right, -down, -forward)).transposed()

cam_data = bpy.data.cameras.new("scancam")
cam_data.angle = math.radians(fov_deg)
cam_data.clip_start = 0.05
cam = bpy.data.objects.new("scancam", cam_data)
cam.matrix_world = Matrix.Translation(centre) @ rot.to_4x4()
bpy.context.scene.collection.objects.link(cam)
scene = bpy.context.scene
scene.camera = cam
scene.render.engine = "BLENDER_WORKBENCH"
scene.display.shading.light = "FLAT"
scene.display.shading.color_type = "TEXTURE"
scene.render.resolution_x, scene.render.resolution_y = 1280, 800
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
print("render_glb: wrote", out)
