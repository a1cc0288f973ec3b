// The Khronos glTF validator (npm gltf-validator) on one .glb / .gltf: prints its report as
// JSON. Usage: node gltf_validate.mjs FILE  (ENVL_NODE_MODULES: scripts/npm_tools.sh's folder)
import fs from "fs";
import path from "path";
import { pathToFileURL } from "url";

const modules = process.env.ENVL_NODE_MODULES;
const validator = (await import(pathToFileURL(path.join(modules, "gltf-validator", "index.js")))).default;
const file = process.argv[2];
const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: file,
  maxIssues: 0, // all of them
  externalResourceFunction: (uri) => Promise.reject(new Error(`no external resource: ${uri}`)),
});
process.stdout.write(JSON.stringify(report));
