// compare.js - the baked glTF in a real browser against the engine's own
// render of the same camera (test/cli/bake.sh runs it):
//   node compare.js MODEL.glb ENGINE.png IDS.pgm SHOT.png
// Serves this folder and the three files on 127.0.0.1, opens view.html in
// headless Chromium (Debian's /usr/bin/chromium, or $CHROMIUM; software
// WebGL through SwiftShader; no sandbox, as CI runs as root), draws the
// model through its first camera, saves the canvas as SHOT.png and
// compares it with ENGINE.png (render --png --exposure EV, same size):
//   - mean absolute difference per channel over the whole image <= 2/255;
//   - among object pixels more than one pixel from a change of object in
//     the engine's item buffer (IDS.pgm, render --ids), 99 % within 8/255;
//   - no background among those pixels (a crack): drawn twice, on black
//     and on magenta, a pixel whose colour follows the background shows it.
// Prints one line of figures per check, exits 1 when one fails.
'use strict';
const fs = require('fs');
const http = require('http');
const path = require('path');
const puppeteer = require('puppeteer-core');

const MEAN_LIMIT = 2, NEAR = 8, NEAR_SHARE = 0.99;

function readPgm(file) {
    const b = fs.readFileSync(file);
    const head = b.toString('latin1', 0, 64).match(/^P5\s+(\d+)\s+(\d+)\s+(\d+)\s/);
    if (!head || head[3] !== '65535')
        throw new Error(`${file}: not a 16-bit binary PGM`);
    const w = Number(head[1]), h = Number(head[2]), at = head[0].length;
    const ids = new Uint32Array(w * h);
    for (let k = 0; k < w * h; k++)
        ids[k] = b.readUInt16BE(at + 2 * k);
    return { w, h, ids };
}

function serve(files) {
    const types = { '.html': 'text/html', '.js': 'text/javascript', '.glb': 'model/gltf-binary',
                    '.png': 'image/png', '.gltf': 'model/gltf+json', '.bin': 'application/octet-stream' };
    const server = http.createServer((req, res) => {
        const url = decodeURIComponent(req.url.split('?')[0]);
        const file = files[url] || path.join(__dirname, path.normalize(url));
        if (!file.startsWith(__dirname) && !Object.values(files).includes(file)) {
            res.writeHead(403).end();
            return;
        }
        fs.readFile(file, (err, data) => {
            if (err) {
                res.writeHead(404).end();
                return;
            }
            res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' });
            res.end(data);
        });
    });
    return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

// The figures of the three checks from RGBA bytes (browser on black and on
// magenta, engine) and the item buffer.
function measure(onBlack, onMagenta, engine, { w, h, ids }) {
    const sum = [0, 0, 0];
    let interior = 0, near = 0, worst = 0, holes = 0, holesAll = 0;
    for (let y = 0; y < h; y++)
        for (let x = 0; x < w; x++) {
            const p = y * w + x;
            let d = 0;
            for (let c = 0; c < 3; c++) {
                const e = Math.abs(onBlack[4 * p + c] - engine[4 * p + c]);
                sum[c] += e;
                d = Math.max(d, e);
            }
            if (!ids[p])
                continue;
            const hole = [0, 1, 2].some((c) => onBlack[4 * p + c] !== onMagenta[4 * p + c]);
            holesAll += hole;
            let edge = false;
            for (let dy = -1; dy <= 1; dy++)
                for (let dx = -1; dx <= 1; dx++) {
                    const xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= w || yy >= h || ids[yy * w + xx] !== ids[p])
                        edge = true;
                }
            if (edge)
                continue;
            interior++;
            near += d <= NEAR;
            worst = Math.max(worst, d);
            holes += hole;
        }
    return { mean: sum.map((s) => s / (w * h)), interior, near, worst, holes, holesAll };
}

async function main() {
    const [model, enginePng, idsPgm, shot] = process.argv.slice(2);
    if (!shot)
        throw new Error('usage: node compare.js MODEL.glb ENGINE.png IDS.pgm SHOT.png');
    const item = readPgm(idsPgm);
    const files = { '/files/model.glb': path.resolve(model), '/files/engine.png': path.resolve(enginePng) };
    const server = await serve(files);
    const base = `http://127.0.0.1:${server.address().port}`;
    const browser = await puppeteer.launch({
        executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
        headless: true,
        args: ['--headless=new', '--no-sandbox', '--use-angle=swiftshader',
               '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--force-color-profile=srgb'],
    });
    try {
        const page = await browser.newPage();
        const logs = [];
        page.on('console', (m) => logs.push(m.text()));
        page.on('pageerror', (e) => logs.push(String(e)));
        await page.goto(`${base}/view.html?model=/files/model.glb&size=${item.w}`);
        const info = await page.evaluate(() => window.ready).catch((e) => {
            throw new Error(`three.js could not load the model: ${e.message || e} ${logs.join(' | ')}`);
        });
        const onBlack = await page.evaluate(() => window.draw([0, 0, 0]));
        const png = await page.evaluate(() => window.png());
        const onMagenta = await page.evaluate(() => window.draw([1, 0, 1]));
        const engine = await page.evaluate(() => window.decode('/files/engine.png'));
        fs.writeFileSync(shot, Buffer.from(png.split(',')[1], 'base64'));
        if (engine.length !== onBlack.length)
            throw new Error(`engine image is not ${item.w}x${item.h}`);
        const m = measure(onBlack, onMagenta, engine, item);
        const share = m.interior ? m.near / m.interior : 0;
        const meanOk = m.mean.every((v) => v <= MEAN_LIMIT);
        console.log(`three.js: ${info.meshes} nodes, ${info.cameras} camera(s), ${item.w}x${item.h}`);
        console.log(`${meanOk ? 'ok  ' : 'FAIL'} mean |three.js - engine| R ${m.mean[0].toFixed(3)} ` +
                    `G ${m.mean[1].toFixed(3)} B ${m.mean[2].toFixed(3)} /255 (limit ${MEAN_LIMIT})`);
        const nearOk = m.interior > 0 && share >= NEAR_SHARE;
        console.log(`${nearOk ? 'ok  ' : 'FAIL'} ${(100 * share).toFixed(3)} % of ${m.interior} ` +
                    `interior object pixels within ${NEAR}/255 (limit ${100 * NEAR_SHARE} %), worst ${m.worst}/255`);
        const holeOk = m.holes === 0;
        console.log(`${holeOk ? 'ok  ' : 'FAIL'} background seen at ${m.holes} interior object pixels ` +
                    `(${m.holesAll} counting object edges)`);
        return meanOk && nearOk && holeOk ? 0 : 1;
    } finally {
        await browser.close();
        server.close();
    }
}

main().then((rc) => process.exit(rc), (e) => {
    console.log(`FAIL browser: ${e.message || e}`);
    process.exit(1);
});
