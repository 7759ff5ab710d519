// Builds the robot app's page, assets/app/robot.html, from src/: esbuild bundles src/main.js (ext-apps'
// App and the live viewer's map renderer) into one script, inlined into src/page.html; ext-apps' license
// is copied beside it. The packages come from `npm ci` into .cache/app (`make app` does both).
//   node assets/app/build.mjs            write robot.html and ext-apps.LICENSE.txt
//   node assets/app/build.mjs --check    exit 1 when the committed files differ from what src/ builds
//   node assets/app/build.mjs --host OUT bundle the tests' host page script (ext-apps' AppBridge) to OUT
import { readFile, writeFile } from "node:fs/promises";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const root = resolve(here, "..", "..");
const modules = process.env.ROBOCOG_APP_MODULES || join(root, ".cache", "app", "node_modules");
const esbuild = await import(pathToFileURL(join(modules, "esbuild", "lib", "main.js")).href);
const PAGE = join(here, "robot.html");
const LICENSE = join(here, "ext-apps.LICENSE.txt");

async function bundle(entry) {
  const out = await esbuild.build({
    entryPoints: [entry],
    absWorkingDir: root,
    nodePaths: [modules],
    bundle: true,
    format: "iife",
    platform: "browser",
    target: "es2022",
    minify: true,
    legalComments: "inline",
    charset: "utf8",
    write: false,
    logLevel: "warning",
  });
  return out.outputFiles[0].text;
}

async function page() {
  const script = (await bundle(join(here, "src", "main.js"))).replaceAll("</script", "<\\/script");
  const shell = await readFile(join(here, "src", "page.html"), "utf8");
  const [before, after] = shell.split("<!--SCRIPT-->");
  if (after === undefined) throw new Error("src/page.html has no <!--SCRIPT--> marker");
  return `${before}<script>${script}</script>${after}`;
}

const license = async () => readFile(join(modules, "@modelcontextprotocol", "ext-apps", "LICENSE"), "utf8");
const args = process.argv.slice(2);
if (args[0] === "--host") {
  await writeFile(args[1], await bundle(join(root, "tests", "app_host", "host.js")));
} else if (args[0] === "--check") {
  const stale = [];
  for (const [path, made] of [[PAGE, await page()], [LICENSE, await license()]]) {
    const committed = await readFile(path, "utf8").catch(() => null);
    if (committed !== made) stale.push(path);
  }
  if (stale.length) {
    console.error(`not what assets/app/src builds (run make app): ${stale.join(", ")}`);
    process.exit(1);
  }
  console.log("assets/app/robot.html is what its sources build");
} else {
  const html = await page();
  await writeFile(PAGE, html);
  await writeFile(LICENSE, await license());
  console.log(`wrote ${PAGE} (${html.length} bytes)`);
}
