#!/usr/bin/env node
// Runs the Khronos glTF validator (npm package gltf-validator, installed into
// .tools/ by scripts/setup.sh) over the given files. Prints a summary per file
// and every error; exits 1 if any file has errors, 2 if the validator is missing.
'use strict';
const fs = require('fs');
const path = require('path');

const root = path.resolve(__dirname, '..');
let validator;
try {
  validator = require(path.join(root, '.tools', 'node_modules', 'gltf-validator'));
} catch (e) {
  console.error('gltf-validator is not installed: run scripts/setup.sh (it installs it into .tools/)');
  process.exit(2);
}

async function main(files) {
  if (files.length === 0) {
    console.error('usage: validate-gltf.cjs FILE.gltf...');
    process.exit(2);
  }
  let failed = 0;
  for (const file of files) {
    const full = path.resolve(file);
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(full)), {
      uri: path.basename(full),
      maxIssues: 100,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(full), decodeURIComponent(uri)), (err, data) => err ? reject(err.toString()) : resolve(data));
      }),
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
    for (const m of i.messages) {
      if (m.severity <= 1) console.log(`  [${m.severity === 0 ? 'error' : 'warning'}] ${m.code}: ${m.message} (${m.pointer || ''})`);
    }
    if (i.numErrors > 0) failed++;
  }
  process.exit(failed ? 1 : 0);
}
main(process.argv.slice(2)).catch((e) => { console.error(e); process.exit(1); });
