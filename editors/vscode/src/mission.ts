// Which Go files are missions. The extension must leave ordinary Go files
// to Go's own tools: a file is a mission when it matches the pattern the
// user set, or else when it has a mission's shape (a `package` clause, no
// `import`, and a drone declared with `var D1 Quadcopter`).

const PACKAGE = /^\s*package\s+\w+/m;
const IMPORT = /^\s*import\b/m;
// `var D1 Quadcopter`, `var D1, D2 Quadcopter` or a grouped `var (`
// whose first line is `D1 Quadcopter`: names and a type, no `=`.
const DRONE_VAR = /^\s*var\s+(\w+(\s*,\s*\w+)*\s+[A-Z]\w*\s*(\/\/.*)?$|\(\s*\n\s*\w+(\s*,\s*\w+)*\s+[A-Z]\w*\s*(\/\/.*)?$)/m;

export function hasMissionShape(text: string): boolean {
  return PACKAGE.test(text) && !IMPORT.test(text) && DRONE_VAR.test(text);
}
