// Validates .glb/.gltf files with the Khronos glTF-Validator (npm package gltf-validator, a
// library: this is its command line for `make test`). Usage: node tests/gltf_validate.js FILE...
// Prints each file's error/warning/info counts and its messages; exits 1 when any file has an
// error (or cannot be read), 2 when the package is missing.
'use strict';
const fs = require('fs');
const path = require('path');
let validator;
try {
    validator = require('gltf-validator');
} catch (e) {
    console.error('gltf_validate.js: the npm package gltf-validator is not installed (npm install gltf-validator; set NODE_PATH to its node_modules)');
    process.exit(2);
}
(async () => {
    let bad = 0;
    for (const file of process.argv.slice(2)) {
        try {
            const bytes = new Uint8Array(fs.readFileSync(file));
            const report = await validator.validateBytes(bytes, {
                uri: path.basename(file),
                externalResourceFunction: (uri) =>
                    Promise.resolve(new Uint8Array(fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(uri))))),
            });
            const s = report.issues;
            console.log(`${file}: ${s.numErrors} errors, ${s.numWarnings} warnings, ${s.numInfos} infos, ${s.numHints} hints (validator ${report.validatorVersion})`);
            for (const m of s.messages) console.log(`  ${['error', 'warning', 'info', 'hint'][m.severity]} ${m.code} ${m.pointer || ''}: ${m.message}`);
            if (s.numErrors > 0) bad = 1;
        } catch (e) {
            console.log(`${file}: cannot validate: ${e.message || e}`);
            bad = 1;
        }
    }
    process.exit(bad);
})();
