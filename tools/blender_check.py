"""blender_check.py - the by-hand check of a baked glTF in Blender (issue 37).

    blender -b --factory-startup --python tools/blender_check.py -- \\
        BAKED.glb ENGINE.png OUT.png

Imports BAKED.glb with Blender's own glTF importer, prints what it made of
it (objects, colour attributes, materials, cameras), renders the first
camera with Cycles at ENGINE.png's size (Standard view transform, no
exposure, a black world, a tiny pixel filter, no denoiser) to OUT.png and
prints the mean absolute difference per channel against ENGINE.png (the
engine's `render --png --exposure EV`, EV as bake printed).

Debian 12's Blender 3.4.1 importer fails on every glTF file with its
default shading option ("module 'numpy' has no attribute 'bool'", numpy
1.24), so the import asks for flat shading, which an unlit bake does not
see.  A development tool, not run by `make test`.
"""
import sys

import bpy

glb, engine, out = sys.argv[sys.argv.index('--') + 1:][:3]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb, import_shading='FLAT')
sc = bpy.context.scene
for o in sorted(sc.objects, key=lambda o: o.name):
    if o.type == 'MESH':
        m = o.data
        print('object %s: %d vertices, %d faces, colours %s, materials %s' % (
            o.name, len(m.vertices), len(m.polygons),
            [(a.name, a.data_type) for a in m.color_attributes],
            [s.material.name for s in o.material_slots]))
    else:
        print('object %s: %s' % (o.name, o.type))
for mat in bpy.data.materials:
    print('material %s: nodes %s' % (mat.name, sorted(n.type for n in mat.node_tree.nodes)))
ref = bpy.data.images.load(engine)
w, h = ref.size
sc.camera = [o for o in sc.objects if o.type == 'CAMERA'][0]
sc.render.engine = 'CYCLES'
sc.cycles.device = 'CPU'
sc.cycles.samples = 16
sc.cycles.use_denoising = False
sc.render.resolution_x, sc.render.resolution_y = w, h
sc.render.resolution_percentage = 100
sc.render.filter_size = 0.01
sc.view_settings.view_transform = 'Standard'
sc.view_settings.look = 'None'
sc.view_settings.exposure = 0
sc.view_settings.gamma = 1
sc.world = bpy.data.worlds.new('black')
sc.world.use_nodes = True
sc.world.node_tree.nodes['Background'].inputs[0].default_value = (0, 0, 0, 1)
sc.render.image_settings.file_format = 'PNG'
sc.render.image_settings.color_depth = '8'
sc.render.filepath = out
bpy.ops.render.render(write_still=True)
got = bpy.data.images.load(out)
a, b = list(got.pixels), list(ref.pixels)  # RGBA floats, the PNGs' bytes / 255
ca, cb = got.channels, ref.channels
s = [0.0, 0.0, 0.0]
near = 0
for p in range(w * h):
    d = [abs(a[ca * p + c] - b[cb * p + c]) * 255 for c in range(3)]
    s = [s[c] + d[c] for c in range(3)]
    near += max(d) <= 8.5
print('Blender %s vs engine: mean |diff| R %.2f G %.2f B %.2f /255, %.2f %% of pixels within 8/255'
      % (bpy.app.version_string, s[0] / (w * h), s[1] / (w * h), s[2] / (w * h), 100 * near / (w * h)))
