# Makes a PBR test asset with Blender's own modelling, UV unwrapping and glTF exporter, so that
# `mf gen --asset` is exercised on a glTF file no part of this project wrote (issue 15: "a real
# asset with UVs ... or generate an equivalent"). Optional: nothing in `make test` needs Blender.
#
#   blender -b --factory-startup -P datasets/blender_asset.py -- OUT.glb [--tex 512] [--seed 1]
#
# The object: Blender's monkey head (Suzanne), subdivided once and smooth-shaded, UVs from Smart
# UV Project. One Principled BSDF material: a base-colour texture (coloured patches on a checker,
# sRGB) and an ORM texture (Non-Color; R occlusion 1, G roughness 0.15-0.9 in bands, B metallic 1
# inside discs, else 0), wired the way Blender's glTF exporter maps them (Separate RGB: G ->
# Roughness, B -> Metallic; the R channel -> a glTF Settings occlusion group is not needed since
# occlusion is 1). Exported as .glb (+Y up, as glTF asks; mf reads it back +Z up).
import math
import random
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    sys.exit("usage: blender -b --factory-startup -P blender_asset.py -- OUT.glb [--tex N] [--seed S]")
out = argv[0]
tex = int(argv[argv.index("--tex") + 1]) if "--tex" in argv else 512
seed = int(argv[argv.index("--seed") + 1]) if "--seed" in argv else 1
rng = random.Random(seed)

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_monkey_add(size=1.0)
obj = bpy.context.active_object
mod = obj.modifiers.new("subsurf", "SUBSURF")
mod.levels = 1
bpy.ops.object.modifier_apply(modifier=mod.name)
bpy.ops.object.shade_smooth()
bpy.ops.object.mode_set(mode="EDIT")
bpy.ops.mesh.select_all(action="SELECT")
bpy.ops.uv.smart_project(angle_limit=math.radians(66.0), island_margin=0.02)
bpy.ops.object.mode_set(mode="OBJECT")

# textures, written pixel by pixel (RGBA floats, row 0 at the bottom as Blender stores them)
palette = [[rng.uniform(0.05, 0.9) for _ in range(3)] for _ in range(6)]
discs = [(rng.random(), rng.random(), rng.uniform(0.04, 0.1)) for _ in range(10)]
kd = [0.0] * (tex * tex * 4)
orm = [0.0] * (tex * tex * 4)
for y in range(tex):
    v = (y + 0.5) / tex
    for x in range(tex):
        u = (x + 0.5) / tex
        i = 4 * (y * tex + x)
        c = palette[(int(u * 8) + int(v * 8)) % len(palette)] if (int(u * 4) + int(v * 4)) % 2 else palette[-1]
        metal = any((u - cx) ** 2 + (v - cy) ** 2 < r * r for cx, cy, r in discs)
        kd[i:i + 4] = [c[0], c[1], c[2], 1.0]
        orm[i:i + 4] = [1.0, 0.15 + 0.75 * (int(v * 5) % 2), 1.0 if metal else 0.0, 1.0]


def image(name, px, colorspace):
    img = bpy.data.images.new(name, tex, tex, alpha=False)
    img.colorspace_settings.name = colorspace
    img.pixels = px
    img.pack()
    return img


mat = bpy.data.materials.new("asset_material")
mat.use_nodes = True
nt = mat.node_tree
bsdf = nt.nodes["Principled BSDF"]
t_kd = nt.nodes.new("ShaderNodeTexImage")
t_kd.image = image("basecolor", kd, "sRGB")
t_orm = nt.nodes.new("ShaderNodeTexImage")
t_orm.image = image("orm", orm, "Non-Color")
sep = nt.nodes.new("ShaderNodeSeparateColor")
nt.links.new(t_kd.outputs["Color"], bsdf.inputs["Base Color"])
nt.links.new(t_orm.outputs["Color"], sep.inputs["Color"])
nt.links.new(sep.outputs["Green"], bsdf.inputs["Roughness"])
nt.links.new(sep.outputs["Blue"], bsdf.inputs["Metallic"])
obj.data.materials.append(mat)

bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", use_selection=False, export_yup=True)
print("blender_asset.py: wrote", out)
