# Renders the lit views of one object with Blender Cycles (Debian's blender 3.4), for
# datasets/ds_cycles.c: blender -b --factory-startup -P ds_cycles.py -- JOB.json
#
# JOB.json (written by ds_cycles_write_job, all paths relative to the job's folder):
#   {"res": R, "samples": S, "bounces": B, "mesh": "mesh.obj", "kd": "kd.exr", "orm": "orm.exr",
#    "views": [{"name": "v000", "c2w": [16 numbers, row-major camera-to-world, OpenGL camera axes],
#               "angle_x": radians, "env": "env_v000.exr" or null (views that share a map name one file),
#               "lights": [{"kind": "sun", "dir": [x, y, z] (towards the light), "rgb": [r, g, b]},
#                          {"kind": "point", "pos": [x, y, z], "rgb": [r, g, b]}]}]}
# World: +Z up, the project's conventions (checked against Blender by ../shared/blender-fixtures).
# Material: Principled BSDF (GGX, specular 0.5, i.e. F0 = 0.04), base colour = kd, roughness and
# metallic = the G and B channels of the ORM texture (Non-Color). Sun "rgb" is the irradiance
# (W/m^2) per channel; point "rgb" is the power (W) per channel, converted by ds_cycles.c.
# Output: <name>.exr per view, RGBA linear float, film transparent (alpha = coverage, colour
# premultiplied), written to <name>.tmp.exr and renamed.
import json
import math
import os
import sys

import bpy
from mathutils import Matrix, Vector

JOB = sys.argv[sys.argv.index("--") + 1]
DIR = os.path.dirname(os.path.abspath(JOB))
job = json.load(open(JOB))


def path(rel):
    return os.path.join(DIR, rel)


bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.render.engine = 'CYCLES'
sc.cycles.device = 'CPU'
sc.cycles.samples = int(job["samples"])
sc.cycles.use_denoising = False
sc.cycles.max_bounces = int(job["bounces"])
sc.cycles.seed = 1
sc.render.resolution_x = sc.render.resolution_y = int(job["res"])
sc.render.resolution_percentage = 100
sc.render.film_transparent = True
sc.view_settings.view_transform = 'Standard'
sc.view_settings.look = 'None'
sc.render.image_settings.file_format = 'OPEN_EXR'
sc.render.image_settings.color_depth = '32'
sc.render.image_settings.color_mode = 'RGBA'

# the mesh, as written (no axis conversion)
bpy.ops.wm.obj_import(filepath=path(job["mesh"]), forward_axis='Y', up_axis='Z')
obj = bpy.context.selected_objects[0]
bpy.ops.object.shade_smooth()

mat = bpy.data.materials.new("m")
mat.use_nodes = True
nt = mat.node_tree
bsdf = nt.nodes["Principled BSDF"]
bsdf.distribution = 'GGX'
bsdf.inputs["Specular"].default_value = 0.5
kd = nt.nodes.new("ShaderNodeTexImage")
kd.image = bpy.data.images.load(path(job["kd"]))
kd.image.colorspace_settings.name = 'Linear'
kd.interpolation = 'Linear'
orm = nt.nodes.new("ShaderNodeTexImage")
orm.image = bpy.data.images.load(path(job["orm"]))
orm.image.colorspace_settings.name = 'Non-Color'
orm.interpolation = 'Linear'
sep = nt.nodes.new("ShaderNodeSeparateColor")
nt.links.new(kd.outputs["Color"], bsdf.inputs["Base Color"])
nt.links.new(orm.outputs["Color"], sep.inputs["Color"])
nt.links.new(sep.outputs[1], bsdf.inputs["Roughness"])
nt.links.new(sep.outputs[2], bsdf.inputs["Metallic"])
obj.data.materials.clear()
obj.data.materials.append(mat)

cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
sc.collection.objects.link(cam)
sc.camera = cam
cam.data.sensor_fit = 'HORIZONTAL'

world = bpy.data.worlds.new("w")
sc.world = world
world.use_nodes = True
wnt = world.node_tree
env_node = wnt.nodes.new("ShaderNodeTexEnvironment")
background = wnt.nodes["Background"]

lights = []
env_file = None
for v in job["views"]:
    for l in lights:
        bpy.data.objects.remove(l, do_unlink=True)
    lights = []
    m = v["c2w"]
    cam.matrix_world = Matrix([m[0:4], m[4:8], m[8:12], m[12:16]])
    cam.data.angle = float(v["angle_x"])
    if v.get("env") and v["env"] == env_file:
        pass  # the previous view's map (ds_cycles.c names one file for views that share it): the world stays as it is
    elif v.get("env"):
        for link in list(background.inputs["Color"].links):
            wnt.links.remove(link)
        env_node.image = bpy.data.images.load(path(v["env"]), check_existing=False)
        wnt.links.new(env_node.outputs["Color"], background.inputs["Color"])
        background.inputs["Strength"].default_value = 1.0
    else:
        for link in list(background.inputs["Color"].links):
            wnt.links.remove(link)
        background.inputs["Color"].default_value = (0, 0, 0, 1)
        background.inputs["Strength"].default_value = 0.0
    for i, l in enumerate(v.get("lights", [])):
        rgb = l["rgb"]
        s = max(rgb)
        data = bpy.data.lights.new(f"l{i}", 'SUN' if l["kind"] == "sun" else 'POINT')
        data.color = tuple(c / s for c in rgb) if s > 0 else (0, 0, 0)
        data.cycles.cast_shadow = True
        o = bpy.data.objects.new(f"l{i}", data)
        sc.collection.objects.link(o)
        if l["kind"] == "sun":
            data.energy = s
            data.angle = 0.0
            o.rotation_euler = Vector(l["dir"]).to_track_quat('Z', 'Y').to_euler()
        else:
            data.energy = s
            data.shadow_soft_size = 0.0
            o.location = Vector(l["pos"])
        lights.append(o)
    env_file = v.get("env")
    out = path(v["name"] + ".tmp.exr")
    sc.render.filepath = out
    bpy.ops.render.render(write_still=True)
    os.replace(out, path(v["name"] + ".exr"))
