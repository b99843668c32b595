#!/usr/bin/env node
// validate.js FILE... — runs the Khronos glTF validator (npm gltf-validator) on
// each .glb/.gltf file and prints "FILE: N errors, M warnings" plus every error
// message. Exit status: 0 when every file has zero errors, 1 otherwise, 2 on
// usage or I/O problems.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validateOne(file) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
        uri: path.basename(file),
        maxIssues: 0,
        // Everything sylva writes is self-contained: refuse external resources.
        externalResourceFunction: (uri) => Promise.reject(new Error('external resource ' + uri)),
    });
    const n = report.issues;
    console.log(`${file}: ${n.numErrors} errors, ${n.numWarnings} warnings, ` +
                `${n.numInfos} infos, ${n.numHints} hints`);
    for (const m of n.messages) {
        if (m.severity === 0 || process.env.VERBOSE)
            console.log(`  [${m.severity}] ${m.code} ${m.pointer || ''}: ${m.message}`);
    }
    return n.numErrors;
}

async function main() {
    const files = process.argv.slice(2);
    if (files.length === 0) {
        console.error('usage: validate.js FILE...');
        process.exit(2);
    }
    let errors = 0;
    for (const f of files) {
        try {
            errors += await validateOne(f);
        } catch (e) {
            console.error(`${f}: ${e.message || e}`);
            process.exit(2);
        }
    }
    console.log(`total errors: ${errors}`);
    process.exit(errors === 0 ? 0 : 1);
}

main();
