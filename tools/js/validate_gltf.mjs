// Khronos' glTF validator on one .glb or .gltf (its external buffers read from beside it); prints the
// validator's report as JSON on stdout (report.issues.numErrors, numWarnings, messages).
//   node tools/js/validate_gltf.mjs FILE
import fs from 'node:fs';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  process.stderr.write('usage: validate_gltf.mjs FILE\n');
  process.exit(2);
}
const external = (uri) => fs.promises.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)));
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file),
  maxIssues: 100,
  externalResourceFunction: external,
}).then(
  (report) => process.stdout.write(JSON.stringify(report)),
  (error) => {
    process.stderr.write(`validate_gltf: ${file}: ${error}\n`);
    process.exit(2);
  },
);
