#!/usr/bin/python3
# Regenerates the bundled example scene examples/torus/ (run: /usr/bin/python3 examples/make_example.py).
# A torus OBJ with UVs and normals, a 32x32 sRGB checker albedo, a 32x32 linear ORM map (roughness
# stripes, half metallic), a transforms.json with 4 cameras, and scene.json using Blender's
# sunset probe (absolute path from Debian's blender-data) plus one sun light.
import json, math, os
from PIL import Image
D = os.path.join(os.path.dirname(os.path.abspath(__file__)), "torus")
os.makedirs(D, exist_ok=True)
R, r, NU, NV = 0.35, 0.15, 48, 24
with open(os.path.join(D, "torus.obj"), "w") as f:
    f.write("# torus R=%g r=%g, %dx%d quads\n" % (R, r, NU, NV))
    for i in range(NU + 1):
        for j in range(NV + 1):
            u, v = 2 * math.pi * i / NU, 2 * math.pi * j / NV
            f.write("v %.6f %.6f %.6f\n" % ((R + r * math.cos(v)) * math.cos(u), (R + r * math.cos(v)) * math.sin(u), r * math.sin(v)))
    for i in range(NU + 1):
        for j in range(NV + 1):
            f.write("vt %.6f %.6f\n" % (i / NU, j / NV))
    for i in range(NU + 1):
        for j in range(NV + 1):
            u, v = 2 * math.pi * i / NU, 2 * math.pi * j / NV
            f.write("vn %.6f %.6f %.6f\n" % (math.cos(v) * math.cos(u), math.cos(v) * math.sin(u), math.sin(v)))
    for i in range(NU):
        for j in range(NV):
            a = i * (NV + 1) + j + 1; b = a + NV + 1; c = b + 1; d = a + 1
            for t in ((a, b, c), (a, c, d)):
                f.write("f %s\n" % " ".join("%d/%d/%d" % (k, k, k) for k in t))
kd = Image.new("RGB", (32, 32))
orm = Image.new("RGB", (32, 32))
for y in range(32):
    for x in range(32):
        kd.putpixel((x, y), (200, 60, 40) if ((x // 4) + (y // 4)) % 2 else (230, 200, 120))
        orm.putpixel((x, y), (255, 40 + 200 * (x // 8) // 3, 255 if y >= 16 else 0))
kd.save(os.path.join(D, "kd.png")); orm.save(os.path.join(D, "orm.png"))
frames = []
for k in range(4):
    a = 2 * math.pi * k / 4 + 0.3
    eye = (1.3 * math.cos(a), 1.3 * math.sin(a), 0.8)
    z = [e / math.sqrt(sum(q * q for q in eye)) for e in eye]
    x = [-z[1], z[0], 0.0]; n = math.sqrt(x[0] ** 2 + x[1] ** 2); x = [q / n for q in x]
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]
    frames.append({"file_path": "./r_%d" % k, "transform_matrix": [[x[0], y[0], z[0], eye[0]], [x[1], y[1], z[1], eye[1]],
                                                                   [x[2], y[2], z[2], eye[2]], [0, 0, 0, 1]]})
json.dump({"camera_angle_x": 0.6911, "frames": frames}, open(os.path.join(D, "transforms.json"), "w"), indent=1)
scene = {"mesh": "torus.obj", "material": {"kd": "kd.png", "orm": "orm.png"},
         "env": {"file": "/usr/share/blender/datafiles/studiolights/world/sunset.exr", "rotation_z_deg": 0, "strength": 1},
         "lights": [{"type": "sun", "dir": [0.3, -0.4, 0.9], "strength": 2.0, "color": [1, 0.95, 0.9]}],
         "cameras": "transforms.json", "width": 128, "height": 128,
         "render": {"spp_sqrt": 4, "pixel_samples": 4, "seed": 0, "lobes": "all"}}
json.dump(scene, open(os.path.join(D, "scene.json"), "w"), indent=1)
