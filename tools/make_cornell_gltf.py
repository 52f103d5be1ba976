#!/usr/bin/env python3
"""make_cornell_gltf.py - writes models/cornell.gltf from the published
Cornell box data (/work/shared/reference/cornell_box.json).

A development tool: its output is committed, so the build never runs it.  The
scene is the same as the polygon model models/cornell.rad: metres, the
commonly used RGB reflectances (white 0.725 0.71 0.68, red 0.63 0.065 0.05,
green 0.14 0.45 0.091), a light of radiance (17, 12, 4) lowered to
y = 0.5487 so it does not overlap the ceiling, the ceiling cut around the
light into four quads, and the slightly bent red wall moved along x onto its
best-fit plane, as cornell.rad does.  Every quad is written as two
triangles, as exporters do, so that the loader's quad merging is exercised;
the blocks hang under a parent node and carry translations, rotations and a
scale, so that the loader's transform composition is exercised too.  The
buffer is embedded as a base64 data URI: the file stands alone.

With --glb PATH it also writes the same scene as a binary .glb (the buffer
in the BIN chunk), which test_gltf reads to check the binary container on a
real model (test/data/gltf/cornell.glb).

Usage: tools/make_cornell_gltf.py [--reference cornell_box.json] [-o models/cornell.gltf]
                                  [--glb test/data/gltf/cornell.glb]
Python 3 standard library only.
"""
import argparse
import base64
import json
import math
import os
import struct
import sys
import tempfile

MM = 0.001  # the reference is in millimetres

WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LIGHT_RADIANCE = (17.0, 12.0, 4.0)
LIGHT_Y = 0.5487        # lowered from the ceiling plane y = 0.5488
HOLE = (0.213, 0.343, 0.227, 0.332)  # light footprint: x0, x1, z0, z1


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def newell_normal(pts):
    """Unit normal of a polygon by Newell's method: the least-squares-like
    plane normal for a slightly bent outline, oriented by its winding."""
    n = [0.0, 0.0, 0.0]
    for i, p in enumerate(pts):
        q = pts[(i + 1) % len(pts)]
        n[0] += (p[1] - q[1]) * (p[2] + q[2])
        n[1] += (p[2] - q[2]) * (p[0] + q[0])
        n[2] += (p[0] - q[0]) * (p[1] + q[1])
    length = math.sqrt(dot(n, n))
    return [c / length for c in n]


def project_to_plane(pts):
    """Moves each point along x onto the plane through the points' centroid
    with their Newell normal (the red wall's best-fit plane), keeping y and z
    so the wall still meets the floor and the ceiling: the same correction as
    models/cornell.rad (0.8 mm at most)."""
    c = [sum(p[k] for p in pts) / len(pts) for k in range(3)]
    n = newell_normal(pts)
    return [[c[0] - (n[1] * (p[1] - c[1]) + n[2] * (p[2] - c[2])) / n[0], p[1], p[2]]
            for p in pts]


def ceiling_quads(y, x_max, z_max):
    """The ceiling rectangle minus the light's footprint, as four quads wound
    like the published ceiling (normal pointing down, -y)."""
    x0, x1, z0, z1 = HOLE

    def rect(xa, xb, za, zb):
        return [[xb, y, za], [xb, y, zb], [xa, y, zb], [xa, y, za]]

    return [rect(0.0, x_max, 0.0, z0),      # camera side of the light
            rect(0.0, x_max, z1, z_max),    # back-wall side
            rect(0.0, x0, z0, z1),          # green-wall side
            rect(x1, x_max, z0, z1)]        # red-wall side


def rot_y(theta):
    """Rotation matrix about +y (rows), and its glTF quaternion (x, y, z, w)."""
    c, s = math.cos(theta), math.sin(theta)
    m = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    q = [0.0, math.sin(theta / 2.0), 0.0, math.cos(theta / 2.0)]
    return m, q


def to_local(p, translation, rot_rows, scale):
    """Inverse of p_world = T + R (S p_local): p_local = S^-1 R^T (p - T)."""
    d = sub(p, translation)
    r = [sum(rot_rows[i][k] * d[i] for i in range(3)) for k in range(3)]  # R^T d
    return [r[k] / scale[k] for k in range(3)]


class Builder:
    """Accumulates meshes into one binary buffer (positions, then indices)."""

    def __init__(self):
        self.positions = bytearray()
        self.indices = bytearray()
        self.meshes = []
        self.accessors = []

    def add_mesh(self, name, quads, material):
        verts, idx = [], []
        for q in quads:
            base = len(verts)
            verts.extend(q)
            # two triangles along the diagonal q0-q2, keeping the quad's winding
            idx.extend([base, base + 1, base + 2, base, base + 2, base + 3])
        pos_off = len(self.positions)
        for v in verts:
            self.positions += struct.pack('<3f', *v)
        f32 = [struct.unpack('<3f', struct.pack('<3f', *v)) for v in verts]
        idx_off = len(self.indices)
        for i in idx:
            self.indices += struct.pack('<H', i)
        while len(self.indices) % 4:
            self.indices += b'\0'
        pa = len(self.accessors)
        self.accessors.append({
            'bufferView': 0, 'byteOffset': pos_off, 'componentType': 5126,
            'count': len(verts), 'type': 'VEC3',
            'min': [min(v[k] for v in f32) for k in range(3)],
            'max': [max(v[k] for v in f32) for k in range(3)]})
        ia = len(self.accessors)
        self.accessors.append({
            'bufferView': 1, 'byteOffset': idx_off, 'componentType': 5123,
            'count': len(idx), 'type': 'SCALAR'})
        self.meshes.append({'name': name, 'primitives': [{
            'attributes': {'POSITION': pa}, 'indices': ia, 'material': material, 'mode': 4}]})
        return len(self.meshes) - 1


def build(ref):
    surf = ref['surfaces']

    def quads_of(name):
        return [[[c * MM for c in v] for v in p['vertices_mm']] for p in surf[name]['polygons']]

    materials = [
        {'name': 'white', 'pbrMetallicRoughness': {
            'baseColorFactor': list(WHITE) + [1.0], 'metallicFactor': 0.0, 'roughnessFactor': 1.0}},
        {'name': 'red', 'pbrMetallicRoughness': {
            'baseColorFactor': list(RED) + [1.0], 'metallicFactor': 0.0, 'roughnessFactor': 1.0}},
        {'name': 'green', 'pbrMetallicRoughness': {
            'baseColorFactor': list(GREEN) + [1.0], 'metallicFactor': 0.0, 'roughnessFactor': 1.0}},
        # emissiveFactor is limited to [0, 1]; the strength carries the scale:
        # (1, 12/17, 4/17) x 17 = radiance (17, 12, 4).
        {'name': 'light', 'pbrMetallicRoughness': {
            'baseColorFactor': [0.0, 0.0, 0.0, 1.0], 'metallicFactor': 0.0, 'roughnessFactor': 1.0},
         'emissiveFactor': [c / LIGHT_RADIANCE[0] for c in LIGHT_RADIANCE],
         'extensions': {'KHR_materials_emissive_strength': {'emissiveStrength': LIGHT_RADIANCE[0]}}},
    ]
    WHITE_M, RED_M, GREEN_M, LIGHT_M = 0, 1, 2, 3

    b = Builder()
    nodes = []

    def node(name, mesh=None, **trs):
        n = {'name': name}
        if mesh is not None:
            n['mesh'] = mesh
        n.update(trs)
        nodes.append(n)
        return len(nodes) - 1

    ceiling = quads_of('ceiling')[0]
    x_max = max(v[0] for v in ceiling)
    z_max = max(v[2] for v in ceiling)
    ceiling_y = ceiling[0][1]

    light = [[v[0], LIGHT_Y, v[2]] for v in quads_of('light')[0]]

    roots = [
        node('floor', b.add_mesh('floor', quads_of('floor'), WHITE_M)),
        node('ceiling', b.add_mesh('ceiling', ceiling_quads(ceiling_y, x_max, z_max), WHITE_M)),
        node('back_wall', b.add_mesh('back_wall', quads_of('back_wall'), WHITE_M)),
        node('left_wall_red', b.add_mesh('left_wall_red',
                                         [project_to_plane(q) for q in quads_of('left_wall_red')],
                                         RED_M)),
        node('right_wall_green', b.add_mesh('right_wall_green', quads_of('right_wall_green'),
                                            GREEN_M)),
        node('light', b.add_mesh('light', [light], LIGHT_M)),
    ]

    # The blocks: a parent node shifted by PARENT; each block's node turns it
    # about y by the angle of one of its sides and (tall block) scales y, so
    # that its mesh is stored in genuinely local coordinates.
    parent_t = [0.25, 0.0, 0.25]
    children = []
    for name, side, scale in (('short_block', ((130.0, 65.0), (290.0, 114.0)), [1.0, 1.0, 1.0]),
                              ('tall_block', ((423.0, 247.0), (472.0, 406.0)), [1.0, 2.0, 1.0])):
        quads = quads_of(name)
        pts = [v for q in quads for v in q]
        centre = [sum(v[k] for v in pts) / len(pts) for k in range(3)]
        centre[1] = 0.0
        (ax, az), (bx, bz) = side
        theta = math.atan2(-(bz - az), bx - ax)  # turns local +x onto that side
        rows, quat = rot_y(theta)
        local_t = sub(centre, parent_t)
        local = [[to_local(v, centre, rows, scale) for v in q] for q in quads]
        trs = {'translation': local_t, 'rotation': quat}
        if scale != [1.0, 1.0, 1.0]:
            trs['scale'] = scale
        children.append(node(name, b.add_mesh(name, local, WHITE_M), **trs))
    blocks = node('blocks', translation=parent_t, children=children)
    roots.append(blocks)

    cam = ref['camera']
    eye = [c * MM for c in cam['position_mm']]
    # A glTF camera looks along its local -z; half a turn about y makes that +z.
    cam_node = node('camera', translation=eye, rotation=[0.0, 1.0, 0.0, 0.0])
    nodes[cam_node]['camera'] = 0
    roots.append(cam_node)
    cameras = [{'name': 'main', 'type': 'perspective', 'perspective': {
        'yfov': math.radians(cam['vertical_fov_deg']), 'aspectRatio': 1.0,
        'znear': 0.01, 'zfar': 100.0}}]

    data = bytes(b.positions) + bytes(b.indices)
    uri = 'data:application/octet-stream;base64,' + base64.b64encode(data).decode('ascii')
    return {
        'asset': {'version': '2.0', 'generator': 'radiosity tools/make_cornell_gltf.py'},
        'extensionsUsed': ['KHR_materials_emissive_strength'],
        'scene': 0,
        'scenes': [{'name': 'cornell_box', 'nodes': roots}],
        'nodes': nodes,
        'meshes': b.meshes,
        'materials': materials,
        'cameras': cameras,
        'accessors': b.accessors,
        'bufferViews': [
            {'buffer': 0, 'byteOffset': 0, 'byteLength': len(b.positions),
             'byteStride': 12, 'target': 34962},
            {'buffer': 0, 'byteOffset': len(b.positions), 'byteLength': len(b.indices),
             'target': 34963}],
        'buffers': [{'byteLength': len(data), 'uri': uri}],
    }


def to_glb(doc):
    """The same document as a .glb: JSON chunk (space padded) + BIN chunk."""
    doc = json.loads(json.dumps(doc))
    uri = doc['buffers'][0].pop('uri')
    data = base64.b64decode(uri.split(',', 1)[1])
    js = json.dumps(doc, separators=(',', ':')).encode('utf-8')
    js += b' ' * (-len(js) % 4)
    data += b'\0' * (-len(data) % 4)
    total = 12 + 8 + len(js) + 8 + len(data)
    return (b'glTF' + struct.pack('<II', 2, total) + struct.pack('<I', len(js)) + b'JSON' + js
            + struct.pack('<I', len(data)) + b'BIN\0' + data)


def write_atomic(path, payload):
    """Temporary file in the same directory, then rename: never a half-written model."""
    path = os.path.abspath(path)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix='.cornell-', suffix='.tmp')
    try:
        with os.fdopen(fd, 'wb') as f:
            f.write(payload)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    print('wrote', path, file=sys.stderr)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--reference', default='/work/shared/reference/cornell_box.json')
    ap.add_argument('-o', '--output', default=os.path.join(here, '..', 'models', 'cornell.gltf'))
    ap.add_argument('--glb', help='also write the scene as a binary .glb here')
    args = ap.parse_args()
    with open(args.reference) as f:
        ref = json.load(f)
    doc = build(ref)
    write_atomic(args.output, (json.dumps(doc, indent=1) + '\n').encode('utf-8'))
    if args.glb:
        write_atomic(args.glb, to_glb(doc))


if __name__ == '__main__':
    main()
