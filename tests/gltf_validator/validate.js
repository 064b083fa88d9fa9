// Runs the Khronos glTF Validator (npm gltf-validator) on each file named on the command line.
// Prints one line per file and every error or warning; exits 1 if any file has an error or a
// warning (infos and hints are allowed), 2 if a file cannot be read or validated.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
    const data = new Uint8Array(fs.readFileSync(file));
    const external = (uri) => fs.promises.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))
        .then((bytes) => new Uint8Array(bytes));
    const report = await validator.validateBytes(data, {uri: path.basename(file), externalResourceFunction: external});
    const {numErrors, numWarnings, messages} = report.issues;
    console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings`);
    const shown = messages.filter((m) => m.severity <= 1);
    for (const m of shown.slice(0, 20))
        console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} at ${m.pointer}: ${m.message}`);
    if (shown.length > 20) console.log(`  ... and ${shown.length - 20} more`);
    return numErrors + numWarnings === 0;
}

(async () => {
    const files = process.argv.slice(2);
    if (files.length === 0) {
        console.error('usage: node validate.js FILE.glb|FILE.gltf ...');
        process.exit(2);
    }
    let clean = true;
    for (const file of files) clean = (await validate(file)) && clean;
    process.exit(clean ? 0 : 1);
})().catch((error) => {
    console.error(`glTF validator failed: ${error}`);
    process.exit(2);
});
