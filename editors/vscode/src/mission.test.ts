// `npm test`: the mission shape against the repository's example missions
// and against ordinary Go files, which must stay Go's.

import * as assert from "assert";
import * as fs from "fs";
import * as path from "path";
import { hasMissionShape } from "./mission";

const examples = path.join(__dirname, "..", "..", "..", "examples");
const missions = fs.readdirSync(examples).filter((f) => f.endsWith(".go"));
assert.ok(missions.length > 0, "no example missions found");
for (const f of missions) {
  assert.ok(hasMissionShape(fs.readFileSync(path.join(examples, f), "utf8")), `${f} is a mission`);
}
assert.ok(hasMissionShape("package M\n\nvar (\n\tD1 Quadcopter\n\tD2 Quadcopter\n)\n"));
const ordinaryGo = [
  'package main\n\nimport "fmt"\n\nvar D1 Quadcopter\n\nfunc main() { fmt.Println(D1) }\n',
  "package main\n\nvar x int\n\nfunc main() {}\n",
  "package main\n\nvar x = Quadcopter{}\n",
  "var D1 Quadcopter\n",
];
for (const text of ordinaryGo) {
  assert.ok(!hasMissionShape(text), `not a mission:\n${text}`);
}
console.log(`mission shape: ${missions.length} examples and ${ordinaryGo.length} Go files told apart`);
