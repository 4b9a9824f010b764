// Bundles the dashboard into one JS and one CSS file (content-hashed names, so
// the daemon serves them with a long cache) and writes index.html naming them.
// Usage: node build.mjs [OUT_DIR]   (default: ../build/web)
import { build } from "esbuild";
import { copyFileSync, mkdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { basename, dirname, resolve } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const out = resolve(process.argv[2] ?? resolve(here, "../build/web"));

rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });

const result = await build({
  entryPoints: [resolve(here, "src/main.ts")],
  bundle: true,
  minify: true,
  sourcemap: true,
  target: ["es2020"],
  entryNames: "[name]-[hash]",
  outdir: out,
  metafile: true,
  logLevel: "warning",
});

const outputs = Object.keys(result.metafile.outputs).map((p) => basename(p));
const js = outputs.find((f) => f.endsWith(".js"));
const css = outputs.find((f) => f.endsWith(".css"));
if (!js || !css) throw new Error(`esbuild produced no JS or CSS: ${outputs.join(", ")}`);

const html = readFileSync(resolve(here, "src/index.html"), "utf8")
  .replace("%CSS%", css)
  .replace("%JS%", js);
writeFileSync(resolve(out, "index.html"), html);
// The tab icon: without one the browser asks for /favicon.ico and gets a 404.
copyFileSync(resolve(here, "src/favicon.svg"), resolve(out, "favicon.svg"));
console.log(`dashboard built in ${out}: index.html, ${js}, ${css}`);
