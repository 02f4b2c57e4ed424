// The Khronos glTF validator on each file named: prints {file: {errors, warnings, infos, messages}}.
//   node validate.mjs FILE.glb [FILE.vrma ...]
import { readFile } from "node:fs/promises";
import validator from "gltf-validator";

const out = {};
for (const file of process.argv.slice(2)) {
  const report = await validator.validateBytes(new Uint8Array(await readFile(file)), { maxIssues: 100 });
  const issues = report.issues;
  out[file] = {
    errors: issues.numErrors, warnings: issues.numWarnings, infos: issues.numInfos,
    messages: issues.messages.map((m) => `${["error", "warning", "info", "hint"][m.severity]} ${m.code} ${m.pointer ?? ""}: ${m.message}`),
  };
}
console.log(JSON.stringify(out));
