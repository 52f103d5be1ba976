#!/usr/bin/env python3
"""make_real_gltf.py - writes test/data/real/: small glTF scenes shaped like
what Blender, three.js and the Khronos samples export, and the images they
use, for the loader's real-world rules (textures, vertex colours, glTF's
default material, orthographic cameras, .glb, ignored features).

A development tool: its output is committed, so the build never runs it.
Everything is generated here from formulas (no third-party data), so the
files carry no licence but the CC0 dedication in test/data/real/README.md,
and the tests can compute what the images hold independently:

  checker.png  16 x 16 RGBA, 8 bits: R = 16x + 8, G = 16y + 8,
               B = 40 where (x//4 + y//4) is even, else 200;
               A = (37x + 11y) mod 256 (alpha must not change the mean)
  bricks.jpg   16 x 16 baseline JPEG, 4:2:0: R = 100 + 5x, G = 80 + 4y,
               B = 60 + 2(x + y)  (lossy: the tests measure the loss)
  glow.png     4 x 4 RGB: every texel (255, 230, 200)

(x the column from the left, y the row from the top.)  The scenes:

  textured.gltf      untextured factors nowhere: a floor whose material has
                     only a baseColorTexture (checker.png, external file,
                     with KHR_texture_transform and a normalTexture), a wall
                     at factor 0.8 x bricks.jpg (external, with
                     KHR_materials_specular), a lamp lit by an
                     emissiveTexture (glow.png as a data URI) x
                     KHR_materials_emissive_strength 4
  no-material.gltf   a floor primitive without a material, beside it a LINES
                     primitive (loose edges), a leaf at alphaMode MASK, a
                     gold plate at metallicFactor 1, a lamp, a point light
                     with a range
  vertex-colors.glb  a floor of 2 x 2 quads with COLOR_0 (normalised unsigned
                     bytes, RGBA) under a plain white material, a wall whose
                     texture (checker.png) sits in the BIN chunk, a lamp
  ortho.gltf         a floor of two halves (0.2 and 0.8) under a
                     directional light of 683 lux (1 W/m^2 per band), seen
                     by an orthographic camera from above (xmag = ymag =
                     1.5); the dark half names KHR_materials_transmission
                     and KHR_materials_volume

With --fuzz-corpus DIR it also writes seeds for the glTF fuzz target:
textured-embedded.gltf (textured.gltf with both images as data URIs, so
that a fuzzer without files reaches the PNG and JPEG decoders),
vertex-colors.glb and ortho.gltf.

Usage: tools/make_real_gltf.py [-o test/data/real] [--fuzz-corpus test/fuzz/corpus/gltf]
Python 3 standard library only.
"""
import argparse
import base64
import json
import math
import os
import struct
import zlib

# ------------------------------------------------------------------ images


def checker_pixel(x, y):
    return (16 * x + 8, 16 * y + 8, 40 if (x // 4 + y // 4) % 2 == 0 else 200,
            (37 * x + 11 * y) % 256)


def bricks_pixel(x, y):
    return (100 + 5 * x, 80 + 4 * y, 60 + 2 * (x + y))


def png(width, height, channels, pixel):
    """A PNG of 8-bit RGB (3) or RGBA (6) pixels, filter 0 on every row."""
    def chunk(tag, data):
        return (struct.pack('>I', len(data)) + tag + data +
                struct.pack('>I', zlib.crc32(tag + data) & 0xffffffff))
    rows = b''.join(b'\0' + bytes(v for x in range(width) for v in pixel(x, y)[:channels])
                    for y in range(height))
    color_type = 6 if channels == 4 else 2
    return (b'\x89PNG\r\n\x1a\n' +
            chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, color_type, 0, 0, 0)) +
            chunk(b'IDAT', zlib.compress(rows, 9)) + chunk(b'IEND', b''))


# A baseline JPEG encoder, small rather than good: YCbCr 4:2:0, flat
# quantisers, and Huffman tables that give every symbol a code of one length
# (valid, if not compact).

ZIGZAG = [0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48,
          41, 34, 27, 20, 13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15,
          23, 30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63]
Q_LUMA, Q_CHROMA = 2, 3
DC_SYMBOLS = list(range(12))                       # sizes 0..11, 4-bit codes
AC_SYMBOLS = [0x00, 0xF0] + [(run << 4) | size for run in range(16) for size in range(1, 11)]


def fdct(block):
    """The 8 x 8 forward DCT of JPEG (ITU T.81, A.3.3), row-major in and out."""
    out = [0.0] * 64
    for v in range(8):
        for u in range(8):
            s = 0.0
            for y in range(8):
                for x in range(8):
                    s += (block[8 * y + x] * math.cos((2 * x + 1) * u * math.pi / 16) *
                          math.cos((2 * y + 1) * v * math.pi / 16))
            cu = 1 / math.sqrt(2) if u == 0 else 1.0
            cv = 1 / math.sqrt(2) if v == 0 else 1.0
            out[8 * v + u] = 0.25 * cu * cv * s
    return out


class BitWriter:
    def __init__(self):
        self.out = bytearray()
        self.acc = 0
        self.n = 0

    def put(self, code, length):
        for k in range(length - 1, -1, -1):
            self.acc = (self.acc << 1) | ((code >> k) & 1)
            self.n += 1
            if self.n == 8:
                self.out.append(self.acc)
                if self.acc == 0xFF:
                    self.out.append(0)  # byte stuffing
                self.acc = 0
                self.n = 0

    def flush(self):
        while self.n:
            self.put(1, 1)  # pad with ones


def magnitude(v):
    """(size category, the bits JPEG sends for v)."""
    size = abs(v).bit_length()
    return size, (v if v >= 0 else v + (1 << size) - 1)


def encode_block(bw, coef, q, prev_dc, dc_len, ac_len):
    quant = [int(round(coef[ZIGZAG[k]] / q)) for k in range(64)]
    size, bits = magnitude(quant[0] - prev_dc)
    bw.put(DC_SYMBOLS.index(size), dc_len)
    bw.put(bits, size)
    run = 0
    for k in range(1, 64):
        if quant[k] == 0:
            run += 1
            continue
        while run > 15:
            bw.put(AC_SYMBOLS.index(0xF0), ac_len)
            run -= 16
        size, bits = magnitude(quant[k])
        bw.put(AC_SYMBOLS.index((run << 4) | size), ac_len)
        bw.put(bits, size)
        run = 0
    if run:
        bw.put(AC_SYMBOLS.index(0x00), ac_len)
    return quant[0]


def jpeg(width, height, pixel):
    assert width % 16 == 0 and height % 16 == 0
    Y, Cb, Cr = [], [], []
    for y in range(height):
        for x in range(width):
            r, g, b = pixel(x, y)
            Y.append(0.299 * r + 0.587 * g + 0.114 * b)
            Cb.append(-0.168736 * r - 0.331264 * g + 0.5 * b + 128)
            Cr.append(0.5 * r - 0.418688 * g - 0.081312 * b + 128)

    def block(plane, pw, bx, by, sub):
        vals = []
        for y in range(8):
            for x in range(8):
                if sub:  # the mean of the 2 x 2 texels under the chroma sample
                    xs, ys = 2 * (bx + x), 2 * (by + y)
                    vals.append(sum(plane[(ys + j) * pw + xs + i] for j in (0, 1) for i in (0, 1))
                                / 4 - 128)
                else:
                    vals.append(plane[(by + y) * pw + bx + x] - 128)
        return fdct(vals)

    dc_len, ac_len = 4, 8
    bw = BitWriter()
    prev = [0, 0, 0]
    for my in range(0, height, 16):
        for mx in range(0, width, 16):
            for (ox, oy) in ((0, 0), (8, 0), (0, 8), (8, 8)):
                prev[0] = encode_block(bw, block(Y, width, mx + ox, my + oy, False), Q_LUMA,
                                       prev[0], dc_len, ac_len)
            prev[1] = encode_block(bw, block(Cb, width, mx // 2, my // 2, True), Q_CHROMA,
                                   prev[1], dc_len, ac_len)
            prev[2] = encode_block(bw, block(Cr, width, mx // 2, my // 2, True), Q_CHROMA,
                                   prev[2], dc_len, ac_len)
    bw.flush()

    def seg(marker, data):
        return struct.pack('>BBH', 0xFF, marker, len(data) + 2) + data

    def dht(cls_id, length, symbols):
        counts = [0] * 16
        counts[length - 1] = len(symbols)
        return bytes([cls_id]) + bytes(counts) + bytes(symbols)

    out = b'\xff\xd8'
    out += seg(0xE0, b'JFIF\0\x01\x01\0\0\x01\0\x01\0\0')
    out += seg(0xDB, bytes([0]) + bytes([Q_LUMA] * 64) + bytes([1]) + bytes([Q_CHROMA] * 64))
    out += seg(0xC0, struct.pack('>BHHB', 8, height, width, 3) +
               bytes([1, 0x22, 0, 2, 0x11, 1, 3, 0x11, 1]))
    out += seg(0xC4, dht(0x00, dc_len, DC_SYMBOLS) + dht(0x10, ac_len, AC_SYMBOLS) +
               dht(0x01, dc_len, DC_SYMBOLS) + dht(0x11, ac_len, AC_SYMBOLS))
    out += seg(0xDA, bytes([3, 1, 0x00, 2, 0x00, 3, 0x00, 0, 63, 0]))
    return out + bytes(bw.out) + b'\xff\xd9'


# -------------------------------------------------------------------- glTF


class Doc:
    """A glTF document under construction: one buffer, accessors and views."""

    def __init__(self, name):
        self.bin = bytearray()
        self.j = {'asset': {'version': '2.0', 'generator': 'radiosity tools/make_real_gltf.py'},
                  'scene': 0, 'scenes': [{'name': name, 'nodes': []}], 'nodes': [],
                  'meshes': [], 'materials': [], 'accessors': [], 'bufferViews': []}

    def view(self, data):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.j['bufferViews'].append({'buffer': 0, 'byteOffset': len(self.bin),
                                      'byteLength': len(data)})
        self.bin += data
        return len(self.j['bufferViews']) - 1

    def accessor(self, data, component, count, kind, **extra):
        acc = {'bufferView': self.view(data), 'componentType': component, 'count': count,
               'type': kind}
        acc.update(extra)
        self.j['accessors'].append(acc)
        return len(self.j['accessors']) - 1

    def positions(self, pts):
        acc = self.accessor(b''.join(struct.pack('<3f', *p) for p in pts), 5126, len(pts), 'VEC3',
                            min=[min(p[k] for p in pts) for k in range(3)],
                            max=[max(p[k] for p in pts) for k in range(3)])
        return acc

    def indices(self, idx):
        return self.accessor(struct.pack('<%dH' % len(idx), *idx), 5123, len(idx), 'SCALAR')

    def material(self, m):
        self.j['materials'].append(m)
        return len(self.j['materials']) - 1

    def mesh(self, name, primitives):
        self.j['meshes'].append({'name': name, 'primitives': primitives})
        return len(self.j['meshes']) - 1

    def node(self, node):
        self.j['nodes'].append(node)
        self.j['scenes'][0]['nodes'].append(len(self.j['nodes']) - 1)
        return len(self.j['nodes']) - 1

    def quad_primitive(self, corners, material=None, **extra):
        """Corners counter-clockwise about the lit side, as two triangles."""
        prim = {'attributes': {'POSITION': self.positions(corners)},
                'indices': self.indices([0, 1, 2, 0, 2, 3])}
        if material is not None:
            prim['material'] = material
        prim.update(extra)
        return prim

    def gltf(self):
        doc = dict(self.j)
        doc['buffers'] = [{'byteLength': len(self.bin),
                           'uri': 'data:application/octet-stream;base64,' +
                                  base64.b64encode(bytes(self.bin)).decode()}]
        return json.dumps(doc, indent=1).encode()

    def glb(self):
        doc = dict(self.j)
        doc['buffers'] = [{'byteLength': len(self.bin)}]
        js = json.dumps(doc, separators=(',', ':')).encode()
        js += b' ' * ((4 - len(js) % 4) % 4)
        bn = bytes(self.bin) + b'\0' * ((4 - len(self.bin) % 4) % 4)
        total = 12 + 8 + len(js) + 8 + len(bn)
        return (b'glTF' + struct.pack('<II', 2, total) + struct.pack('<I', len(js)) + b'JSON' +
                js + struct.pack('<I', len(bn)) + b'BIN\0' + bn)


FLOOR = [(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)]           # faces +y
WALL = [(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)]          # faces +z
LAMP = [(-0.3, 1.9, -0.3), (0.3, 1.9, -0.3), (0.3, 1.9, 0.3), (-0.3, 1.9, 0.3)]  # faces -y
LAMP_MATERIAL = {'name': 'lamp', 'pbrMetallicRoughness': {'baseColorFactor': [0, 0, 0, 1]},
                 'emissiveFactor': [4, 4, 4]}
# Looks from (0, 1, 3) along -z (glTF cameras look down their -z).
FRONT_CAMERA = {'name': 'front', 'camera': 0, 'translation': [0, 1, 3]}
PERSPECTIVE = {'name': 'front', 'type': 'perspective',
               'perspective': {'yfov': 0.9, 'znear': 0.05, 'aspectRatio': 1.0}}


def data_uri(mime, payload):
    return 'data:%s;base64,%s' % (mime, base64.b64encode(payload).decode())


def textured(embedded=False):
    d = Doc('textured')
    d.j['images'] = [{'uri': data_uri('image/png', png(16, 16, 4, checker_pixel))
                             if embedded else 'checker.png', 'name': 'checker'},
                     {'uri': data_uri('image/jpeg', jpeg(16, 16, bricks_pixel))
                             if embedded else 'bricks.jpg', 'name': 'bricks'},
                     {'uri': 'data:image/png;base64,' +
                             base64.b64encode(png(4, 4, 3, lambda x, y: (255, 230, 200))).decode(),
                      'name': 'glow'}]
    d.j['samplers'] = [{'magFilter': 9729, 'minFilter': 9987}]
    d.j['textures'] = [{'source': 0, 'sampler': 0}, {'source': 1, 'sampler': 0},
                       {'source': 2}]
    d.j['extensionsUsed'] = ['KHR_texture_transform', 'KHR_materials_specular',
                             'KHR_materials_emissive_strength']
    floor = d.material({'name': 'checker floor', 'pbrMetallicRoughness': {
        'baseColorTexture': {'index': 0, 'extensions': {'KHR_texture_transform': {
            'scale': [4, 4]}}}, 'metallicFactor': 0},
        'normalTexture': {'index': 0}})
    wall = d.material({'name': 'bricks', 'pbrMetallicRoughness': {
        'baseColorFactor': [0.8, 0.8, 0.8, 1], 'baseColorTexture': {'index': 1},
        'metallicFactor': 0}, 'extensions': {'KHR_materials_specular': {'specularFactor': 0.3}}})
    lamp = d.material({'name': 'lamp', 'pbrMetallicRoughness': {'baseColorFactor': [0, 0, 0, 1]},
                       'emissiveFactor': [1, 1, 1], 'emissiveTexture': {'index': 2},
                       'extensions': {'KHR_materials_emissive_strength':
                                      {'emissiveStrength': 4}}})
    d.node({'name': 'floor', 'mesh': d.mesh('floor', [d.quad_primitive(FLOOR, floor)])})
    d.node({'name': 'wall', 'mesh': d.mesh('wall', [d.quad_primitive(WALL, wall)])})
    d.node({'name': 'lamp', 'mesh': d.mesh('lamp', [d.quad_primitive(LAMP, lamp)])})
    d.j['cameras'] = [PERSPECTIVE]
    d.node(FRONT_CAMERA)
    return d


def no_material():
    d = Doc('no-material')
    lamp = d.material(LAMP_MATERIAL)
    leaf = d.material({'name': 'leaf', 'alphaMode': 'MASK', 'alphaCutoff': 0.5,
                       'pbrMetallicRoughness': {'baseColorFactor': [0.2, 0.5, 0.1, 1],
                                                'metallicFactor': 0}})
    gold = d.material({'name': 'gold', 'pbrMetallicRoughness': {
        'baseColorFactor': [0.9, 0.7, 0.3, 1], 'metallicFactor': 1, 'roughnessFactor': 0.3}})
    edges = {'attributes': {'POSITION': d.positions([(-1, 0.01, 1), (1, 0.01, -1)])},
             'mode': 1}
    d.node({'name': 'floor', 'mesh': d.mesh('floor', [d.quad_primitive(FLOOR), edges])})
    d.node({'name': 'leaf', 'mesh': d.mesh('leaf', [d.quad_primitive(
        [(-0.9, 0, -0.98), (-0.5, 0, -0.98), (-0.5, 0.4, -0.98), (-0.9, 0.4, -0.98)], leaf)])})
    d.node({'name': 'gold', 'mesh': d.mesh('gold', [d.quad_primitive(
        [(0.5, 0, -0.98), (0.9, 0, -0.98), (0.9, 0.4, -0.98), (0.5, 0.4, -0.98)], gold)])})
    d.node({'name': 'lamp', 'mesh': d.mesh('lamp', [d.quad_primitive(LAMP, lamp)])})
    d.j['extensionsUsed'] = ['KHR_lights_punctual']
    d.j['extensions'] = {'KHR_lights_punctual': {'lights': [
        {'name': 'bulb', 'type': 'point', 'color': [1, 0.9, 0.8], 'intensity': 50,
         'range': 10}]}}
    d.node({'name': 'bulb', 'translation': [0.5, 1.5, 0.5],
            'extensions': {'KHR_lights_punctual': {'light': 0}}})
    d.j['cameras'] = [PERSPECTIVE]
    d.node(FRONT_CAMERA)
    return d


# COLOR_0 of the 3 x 3 floor grid, row by row from z = 1 to z = -1 and x = -1
# to 1 (RGBA bytes): the first quad's corners are white, so its ρ reaches 1
# and is clamped.
GRID_COLORS = [(255, 255, 255, 255), (255, 255, 255, 255), (200, 40, 40, 255),
               (255, 255, 255, 128), (255, 255, 255, 255), (40, 200, 40, 255),
               (40, 40, 200, 255), (120, 120, 120, 255), (10, 10, 10, 0)]


def vertex_colors():
    d = Doc('vertex-colors')
    pts = [(-1 + x, 0, 1 - z) for z in range(3) for x in range(3)]
    idx = []
    for z in range(2):
        for x in range(2):
            a = 3 * z + x
            idx += [a, a + 1, a + 4, a, a + 4, a + 3]
    color = d.accessor(b''.join(bytes(c) for c in GRID_COLORS), 5121, 9, 'VEC4',
                       normalized=True)
    painted = d.material({'name': 'painted'})
    label_view = d.view(png(16, 16, 4, checker_pixel))
    d.j['images'] = [{'bufferView': label_view, 'mimeType': 'image/png', 'name': 'label'}]
    d.j['textures'] = [{'source': 0}]
    label = d.material({'name': 'label', 'pbrMetallicRoughness': {
        'baseColorFactor': [0.5, 0.5, 0.5, 1], 'baseColorTexture': {'index': 0},
        'metallicFactor': 0}})
    lamp = d.material(LAMP_MATERIAL)
    d.node({'name': 'floor', 'mesh': d.mesh('floor', [{
        'attributes': {'POSITION': d.positions(pts), 'COLOR_0': color},
        'indices': d.indices(idx), 'material': painted}])})
    d.node({'name': 'wall', 'mesh': d.mesh('wall', [d.quad_primitive(WALL, label)])})
    d.node({'name': 'lamp', 'mesh': d.mesh('lamp', [d.quad_primitive(LAMP, lamp)])})
    d.j['cameras'] = [PERSPECTIVE]
    d.node(FRONT_CAMERA)
    return d


def ortho():
    d = Doc('ortho')
    d.j['extensionsUsed'] = ['KHR_lights_punctual', 'KHR_materials_transmission',
                             'KHR_materials_volume']
    dark = d.material({'name': 'dark', 'pbrMetallicRoughness': {
        'baseColorFactor': [0.2, 0.2, 0.2, 1], 'metallicFactor': 0},
        'extensions': {'KHR_materials_transmission': {'transmissionFactor': 0.5},
                       'KHR_materials_volume': {'thicknessFactor': 0.1}}})
    light = d.material({'name': 'light', 'pbrMetallicRoughness': {
        'baseColorFactor': [0.8, 0.8, 0.8, 1], 'metallicFactor': 0}})
    d.node({'name': 'floor', 'mesh': d.mesh('floor', [
        d.quad_primitive([(-1, 0, 1), (0, 0, 1), (0, 0, -1), (-1, 0, -1)], dark),
        d.quad_primitive([(0, 0, 1), (1, 0, 1), (1, 0, -1), (0, 0, -1)], light)])})
    d.j['extensions'] = {'KHR_lights_punctual': {'lights': [
        {'name': 'sun', 'type': 'directional', 'intensity': 683}]}}
    # A node's -z is the light's and camera's direction: rotate -90 degrees
    # about x so that -z points down (-y) and the camera's up (+y) is -z.
    down = [-math.sqrt(0.5), 0, 0, math.sqrt(0.5)]
    d.node({'name': 'sun', 'rotation': down, 'extensions': {'KHR_lights_punctual': {'light': 0}}})
    d.j['cameras'] = [{'name': 'plan', 'type': 'orthographic',
                       'orthographic': {'xmag': 1.5, 'ymag': 1.5, 'znear': 0.1, 'zfar': 20}}]
    d.node({'name': 'plan', 'camera': 0, 'translation': [0, 5, 0], 'rotation': down})
    return d


def write(path, payload):
    tmp = path + '.tmp'
    with open(tmp, 'wb') as f:
        f.write(payload)
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('-o', default='test/data/real', help='output directory')
    ap.add_argument('--fuzz-corpus', help='also write fuzz seeds into this directory')
    args = ap.parse_args()
    out = args.o
    os.makedirs(out, exist_ok=True)
    write(os.path.join(out, 'checker.png'), png(16, 16, 4, checker_pixel))
    write(os.path.join(out, 'bricks.jpg'), jpeg(16, 16, bricks_pixel))
    write(os.path.join(out, 'textured.gltf'), textured().gltf())
    write(os.path.join(out, 'no-material.gltf'), no_material().gltf())
    write(os.path.join(out, 'vertex-colors.glb'), vertex_colors().glb())
    write(os.path.join(out, 'ortho.gltf'), ortho().gltf())
    if args.fuzz_corpus:
        seeds = args.fuzz_corpus
        write(os.path.join(seeds, 'textured-embedded.gltf'), textured(embedded=True).gltf())
        write(os.path.join(seeds, 'vertex-colors.glb'), vertex_colors().glb())
        write(os.path.join(seeds, 'ortho.gltf'), ortho().gltf())


if __name__ == '__main__':
    main()
