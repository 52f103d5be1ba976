// validate.js - runs the Khronos glTF Validator (npm gltf-validator) on each
// file named: prints "FILE: E errors, W warnings" and every error, exits 1
// when any file has an error (or cannot be read).  A .gltf's external
// buffers and images are read from beside it.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function one(file) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
        uri: path.basename(file),
        maxIssues: 100,
        externalResourceFunction: (uri) => new Promise((resolve, reject) => {
            const p = path.join(path.dirname(file), decodeURIComponent(uri));
            fs.readFile(p, (err, data) => (err ? reject(err) : resolve(new Uint8Array(data))));
        }),
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings`);
    for (const m of i.messages)
        if (m.severity === 0)
            console.log(`  error ${m.code} ${m.pointer || ''}: ${m.message}`);
    return i.numErrors;
}

(async () => {
    let errors = 0;
    for (const f of process.argv.slice(2)) {
        try {
            errors += await one(f);
        } catch (e) {
            console.log(`${f}: cannot validate: ${e.message || e}`);
            errors++;
        }
    }
    process.exit(errors ? 1 : 0);
})();
