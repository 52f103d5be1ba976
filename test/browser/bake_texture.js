// bake_texture.js - the textured bake's fixture and its independent check
// (test/cli/bake_texture.sh).
//
//   node bake_texture.js make DIR
//     writes DIR/room.gltf, room.bin and checker.png: a closed room 2 × 1 × 2
//     lit by a small lamp under its ceiling, whose floor (material 'checker')
//     samples a 4 × 4 PNG checker with baseColorFactor [0.9, 0.8, 0.7, 1] and
//     a sampler of its own.  The floor is four unit cells, two triangles
//     each, with vertices of their own, and TEXCOORD_0 an affine function of
//     the position: u = 0.5 x + 0.25 + 0.5 i, v = 0.75 z - 0.125, i the cell's
//     column (floor(x)), so the line x = 1 is a UV seam.
//
//   node bake_texture.js check OUT.glb|OUT.gltf EV DIR
//     reads a bake of that room at exposure EV and checks, from the file
//     alone: the floor's primitive has TEXCOORD_0, and every vertex of every
//     floor triangle has the (u, v) of the cell the triangle lies in, within
//     1e-5 (element vertices too, and across the seam); COLOR_0 × ρ̄ equals
//     _RADIANCE × 2^EV within 1/65535 per band where that is below 1, and
//     COLOR_0 is 1 where it is not (ρ̄: the material's extras.reflectance);
//     the material keeps the texture, factor and sampler; the image's bytes
//     are checker.png's; untextured primitives have no TEXCOORD_0.  Prints
//     one line of figures; exits 1 on the first failure.
'use strict';
const fs = require('fs');
const path = require('path');
const zlib = require('zlib');

const FACTOR = [0.9, 0.8, 0.7, 1];
const SAMPLER = {magFilter: 9728, minFilter: 9728, wrapS: 33071, wrapT: 10497};

function expectedUV(x, z, cell) {
    return [0.5 * x + 0.25 + 0.5 * cell, 0.75 * z - 0.125];
}

// ---------------------------------------------------------------- fixture

function chunk(type, data) {
    const len = Buffer.alloc(4);
    len.writeUInt32BE(data.length);
    const td = Buffer.concat([Buffer.from(type, 'ascii'), data]);
    const crc = Buffer.alloc(4);
    crc.writeUInt32BE(zlib.crc32(td) >>> 0);
    return Buffer.concat([len, td, crc]);
}

// A 4 × 4 RGB checker of two sRGB greys, 8 bits.
function checkerPng() {
    const rows = [];
    for (let y = 0; y < 4; y++) {
        const row = [0];
        for (let x = 0; x < 4; x++) {
            const v = (x + y) % 2 ? 40 : 230;
            row.push(v, v, v);
        }
        rows.push(Buffer.from(row));
    }
    const ihdr = Buffer.alloc(13);
    ihdr.writeUInt32BE(4, 0);
    ihdr.writeUInt32BE(4, 4);
    ihdr[8] = 8; // bit depth
    ihdr[9] = 2; // RGB
    return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
                          chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(Buffer.concat(rows))),
                          chunk('IEND', Buffer.alloc(0))]);
}

// Quads as [corner0..3] (counter-clockwise about the front), each two
// triangles; uv(p) gives a corner's TEXCOORD_0 or null.
function make(dir) {
    const parts = [];
    const box = (name, material, quads, uv) => parts.push({name, material, quads, uv});
    const floor = [];
    for (let i = 0; i < 2; i++)
        for (let j = 0; j < 2; j++)
            floor.push([[i, 0, j], [i, 0, j + 1], [i + 1, 0, j + 1], [i + 1, 0, j]]);
    box('floor', 0, floor, (p, q) => expectedUV(p[0], p[2], Math.floor((q[0][0] + q[2][0]) / 2)));
    box('ceiling', 1, [[[0, 1, 0], [2, 1, 0], [2, 1, 2], [0, 1, 2]]], null);
    box('walls', 1, [[[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]],
                     [[0, 0, 2], [0, 1, 2], [2, 1, 2], [2, 0, 2]],
                     [[0, 0, 0], [0, 1, 0], [0, 1, 2], [0, 0, 2]],
                     [[2, 0, 0], [2, 0, 2], [2, 1, 2], [2, 1, 0]]], null);
    box('lamp', 2, [[[0.8, 0.99, 0.8], [1.2, 0.99, 0.8], [1.2, 0.99, 1.2], [0.8, 0.99, 1.2]]], null);

    const bin = [];
    let offset = 0;
    const views = [], accessors = [], meshes = [], nodes = [];
    const addView = (buf) => {
        views.push({buffer: 0, byteOffset: offset, byteLength: buf.length});
        bin.push(buf);
        offset += buf.length;
        return views.length - 1;
    };
    for (const part of parts) {
        const pos = [], uvs = [], idx = [];
        for (const q of part.quads) {
            const base = pos.length / 3;
            for (const p of q) {
                pos.push(...p);
                if (part.uv)
                    uvs.push(...part.uv(p, q));
            }
            idx.push(base, base + 1, base + 2, base, base + 2, base + 3);
        }
        const lo = [0, 1, 2].map((c) => Math.min(...pos.filter((_, k) => k % 3 === c)));
        const hi = [0, 1, 2].map((c) => Math.max(...pos.filter((_, k) => k % 3 === c)));
        const attributes = {POSITION: accessors.length};
        accessors.push({bufferView: addView(Buffer.from(new Float32Array(pos).buffer)),
                        componentType: 5126, count: pos.length / 3, type: 'VEC3', min: lo, max: hi});
        if (part.uv) {
            attributes.TEXCOORD_0 = accessors.length;
            accessors.push({bufferView: addView(Buffer.from(new Float32Array(uvs).buffer)),
                            componentType: 5126, count: uvs.length / 2, type: 'VEC2'});
        }
        const indices = accessors.length;
        accessors.push({bufferView: addView(Buffer.from(new Uint32Array(idx).buffer)),
                        componentType: 5125, count: idx.length, type: 'SCALAR'});
        nodes.push({name: part.name, mesh: meshes.length});
        meshes.push({name: part.name, primitives: [{attributes, indices, material: part.material}]});
    }
    const doc = {
        asset: {version: '2.0', generator: 'radiosity test/browser/bake_texture.js'},
        scene: 0, scenes: [{nodes: nodes.map((_, k) => k)}], nodes, meshes,
        materials: [
            {name: 'checker', pbrMetallicRoughness: {baseColorFactor: FACTOR, baseColorTexture: {index: 0},
                                                     metallicFactor: 0}},
            {name: 'white', pbrMetallicRoughness: {baseColorFactor: [0.5, 0.5, 0.5, 1], metallicFactor: 0}},
            {name: 'lamp', pbrMetallicRoughness: {baseColorFactor: [0, 0, 0, 1], metallicFactor: 0},
             emissiveFactor: [1, 1, 1]},
        ],
        textures: [{source: 0, sampler: 0}],
        samplers: [SAMPLER],
        images: [{uri: 'checker.png'}],
        buffers: [{uri: 'room.bin', byteLength: offset}],
        bufferViews: views, accessors,
    };
    fs.writeFileSync(path.join(dir, 'room.bin'), Buffer.concat(bin));
    fs.writeFileSync(path.join(dir, 'room.gltf'), JSON.stringify(doc));
    fs.writeFileSync(path.join(dir, 'checker.png'), checkerPng());
}

// ------------------------------------------------------------------ check

function fail(msg) {
    console.log(`FAIL ${msg}`);
    process.exit(1);
}

function load(file) {
    const b = fs.readFileSync(file);
    if (file.endsWith('.glb')) {
        const jlen = b.readUInt32LE(12);
        const json = JSON.parse(b.subarray(20, 20 + jlen).toString('utf8'));
        return {json, bin: b.subarray(28 + jlen, 28 + jlen + b.readUInt32LE(20 + jlen))};
    }
    const json = JSON.parse(b.toString('utf8'));
    return {json, bin: fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(json.buffers[0].uri)))};
}

// Accessor k as an array of tuples of numbers.
function read(g, k) {
    const a = g.json.accessors[k], v = g.json.bufferViews[a.bufferView];
    const width = {SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4}[a.type];
    const size = {5126: 4, 5125: 4, 5123: 2}[a.componentType];
    const stride = v.byteStride || width * size, out = [];
    for (let i = 0; i < a.count; i++) {
        const t = [];
        for (let c = 0; c < width; c++) {
            const at = (v.byteOffset || 0) + (a.byteOffset || 0) + i * stride + c * size;
            t.push(a.componentType === 5126 ? g.bin.readFloatLE(at)
                   : a.componentType === 5125 ? g.bin.readUInt32LE(at) : g.bin.readUInt16LE(at));
        }
        out.push(t);
    }
    return out;
}

function checkMaterial(g, dir) {
    const mats = g.json.materials;
    const m = mats.findIndex((x) => x.name === 'checker');
    const pbr = m >= 0 ? mats[m].pbrMetallicRoughness : null;
    if (!pbr || !pbr.baseColorTexture || !mats[m].extensions || !mats[m].extensions.KHR_materials_unlit)
        fail('material checker: no baseColorTexture or not unlit');
    if (pbr.baseColorFactor.some((f, c) => Math.abs(f - FACTOR[c]) > 1e-7))
        fail(`baseColorFactor ${pbr.baseColorFactor}`);
    const tex = g.json.textures[pbr.baseColorTexture.index];
    const smp = g.json.samplers[tex.sampler];
    for (const k of Object.keys(SAMPLER))
        if (smp[k] !== SAMPLER[k])
            fail(`sampler ${k} ${smp[k]}, input ${SAMPLER[k]}`);
    const img = g.json.images[tex.source], v = g.json.bufferViews[img.bufferView];
    const bytes = g.bin.subarray(v.byteOffset, v.byteOffset + v.byteLength);
    if (img.mimeType !== 'image/png' || !bytes.equals(fs.readFileSync(path.join(dir, 'checker.png'))))
        fail('the image is not checker.png byte for byte');
    return {m, rho: mats[m].extras.reflectance, png: bytes.length};
}

// The floor's triangles: each vertex's TEXCOORD_0 against its cell's function.
function checkUV(uv, pos, idx, st) {
    for (let t = 0; t < idx.length; t += 3) {
        const tri = [idx[t][0], idx[t + 1][0], idx[t + 2][0]];
        const cx = tri.reduce((s, k) => s + pos[k][0], 0) / 3;
        for (const k of tri) {
            const [eu, ev] = expectedUV(pos[k][0], pos[k][2], Math.floor(cx));
            st.uvErr = Math.max(st.uvErr, Math.abs(uv[k][0] - eu), Math.abs(uv[k][1] - ev));
            if (Math.abs(pos[k][1]) > 1e-6)
                fail(`a floor vertex at y = ${pos[k][1]}`);
        }
    }
}

// COLOR_0 × ρ̄ against _RADIANCE × 2^EV, per band.
function checkLight(col, rad, rho, scale, st) {
    for (let k = 0; k < col.length; k++)
        for (let c = 0; c < 3; c++) {
            const want = rad[k][c] * scale / rho[c], got = col[k][c] / 65535;
            if (want >= 1) {
                st.clamped++;
                if (got !== 1)
                    fail(`vertex ${k} band ${c}: COLOR_0 ${got}, L/ρ̄·2^EV = ${want} >= 1`);
                continue;
            }
            st.unclamped++;
            st.colErr = Math.max(st.colErr, Math.abs(got * rho[c] - rad[k][c] * scale));
        }
}

function check(file, ev, dir) {
    const g = load(file);
    const {m, rho, png} = checkMaterial(g, dir);
    const st = {uvErr: 0, colErr: 0, unclamped: 0, clamped: 0, vertices: 0};
    for (const mesh of g.json.meshes)
        for (const p of mesh.primitives) {
            if (p.material !== m) {
                if ('TEXCOORD_0' in p.attributes)
                    fail(`mesh ${mesh.name}: TEXCOORD_0 on an untextured material`);
                continue;
            }
            if (!('TEXCOORD_0' in p.attributes))
                fail('the floor has no TEXCOORD_0');
            const pos = read(g, p.attributes.POSITION), uv = read(g, p.attributes.TEXCOORD_0);
            checkUV(uv, pos, read(g, p.indices), st);
            checkLight(read(g, p.attributes.COLOR_0), read(g, p.attributes._RADIANCE), rho,
                       Math.pow(2, ev), st);
            st.vertices += pos.length;
        }
    // 12 corners with the seam: anything more is element and fan vertices
    if (st.vertices <= 12 || st.unclamped === 0)
        fail(`${st.vertices} floor vertices, ${st.unclamped} unclamped bands`);
    // Measured on the fixture: TEXCOORD_0 off by 0 (the functions are exact
    // in binary at every element vertex), COLOR_0 × ρ̄ by 0.18/65535; the
    // limits are the issue's, 1e-5 and 1/65535.
    if (st.uvErr > 1e-5)
        fail(`TEXCOORD_0 off by ${st.uvErr}`);
    if (st.colErr > 1 / 65535)
        fail(`COLOR_0 × ρ̄ off by ${st.colErr * 65535} / 65535`);
    console.log(`${st.vertices} floor vertices: TEXCOORD_0 within ${st.uvErr.toExponential(1)} of the ` +
                `cell's function; COLOR_0 × ρ̄ within ${(st.colErr * 65535).toFixed(2)}/65535 of ` +
                `_RADIANCE·2^EV (${st.unclamped} bands, ${st.clamped} clamped to 1); ` +
                `image ${png} bytes as the input's`);
}

if (process.argv[2] === 'make')
    make(process.argv[3]);
else if (process.argv[2] === 'check')
    check(process.argv[3], Number(process.argv[4]), process.argv[5]);
else
    fail('usage: bake_texture.js make DIR | check FILE EV DIR');
