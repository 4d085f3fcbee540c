// The page of `dofcache view` in a real browser: headless Chromium driven over the DevTools
// Protocol (puppeteer-core, pointed at the system's browser). Run by tests/view/browser_test.sh:
//   node browser_test.js DOFCACHE_EXE SCENE OUT_DIR
// Starts `dofcache view` on a free port, loads the page, clicks a near and a far object and checks
// on the drawn image that the clicked region becomes sharp and the other blurred, changes the
// f-number, waits for the reference's first pass and the error between it and the preview, saves
// the image through the page's button, and writes OUT_DIR/view.png (a screenshot) and
// OUT_DIR/browser_test.json (the timings). Exit status 0: passed, 1: failed.
"use strict";
const {spawn} = require("child_process");
const fs = require("fs");
const path = require("path");
const puppeteer = require("puppeteer-core");

const [exe, scene, outDir] = process.argv.slice(2);
const chromium = process.env.CHROMIUM || "/usr/bin/chromium";
const width = +(process.env.VIEW_WIDTH || 320);
fs.mkdirSync(outDir, {recursive: true});

function fail(message) { throw new Error(message); }
function check(condition, message) {
  console.log((condition ? "ok     " : "FAILED ") + message);
  if (!condition) fail(message);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Starts the server; resolves with its address once printed.
function startServer() {
  const args = ["view", scene, "--port", "0", "--width", String(width), "--input-spp", "4",
                "--reference-pass-spp", "1", "--reference-max-spp", "4",
                "--keyframes", path.join(outDir, "keyframes.json")];
  fs.rmSync(path.join(outDir, "keyframes.json"), {force: true});
  const child = spawn(exe, args, {stdio: ["ignore", "pipe", "inherit"]});
  const started = Date.now();
  return new Promise((resolve, reject) => {
    let out = "";
    child.stdout.on("data", (d) => {
      out += d;
      const m = out.match(/view\s+(http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]+)/);
      if (m) resolve({child, url: m[1], started});
    });
    child.on("exit", (code) => reject(new Error("dofcache view exited with " + code + ": " + out)));
    setTimeout(() => reject(new Error("no address printed within 30 s")), 30000);
  });
}

// Mean squared difference of horizontally and vertically neighbouring pixels (luminance, 0-255)
// in the (2r+1)^2 window around (x, y) of the main canvas: high where the image is sharp.
async function sharpness(page, x, y, r) {
  return page.evaluate((x, y, r) => {
    const c = document.getElementById("main");
    const d = c.getContext("2d").getImageData(x - r, y - r, 2 * r + 1, 2 * r + 1);
    const w = d.width, h = d.height, px = d.data;
    const lum = (i) => 0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2];
    let sum = 0, n = 0;
    for (let j = 0; j < h - 1; ++j)
      for (let i = 0; i < w - 1; ++i) {
        const k = 4 * (j * w + i);
        const a = lum(k), b = lum(k + 4), c2 = lum(k + 4 * w);
        sum += (a - b) * (a - b) + (a - c2) * (a - c2);
        n += 2;
      }
    return sum / n;
  }, x, y, r);
}

// Waits until the page has answered a lens change after `previous` with a drawn preview.
async function waitForChange(page, previous) {
  await page.waitForFunction((previous) => window.dofcacheView.changes > previous,
                             {timeout: 20000, polling: 20}, previous);
}

// Points on a grid whose neighbourhood (+-d pixels) sees one surface at one depth.
async function flatPoints(page, w, h, d) {
  return page.evaluate(async (w, h, d) => {
    const token = new URLSearchParams(location.search).get("token");
    const depth = async (x, y) => (await (await fetch("/api/depth?x=" + x + "&y=" + y,
        {headers: {"X-Dofcache-Token": token}})).json()).depth;
    const points = [];
    for (let y = 2 * d; y < h - 2 * d; y += d)
      for (let x = 2 * d; x < w - 2 * d; x += d) {
        const z = await depth(x, y);
        if (z === null) continue;
        let flat = true;
        for (const [dx, dy] of [[-d, 0], [d, 0], [0, -d], [0, d]]) {
          const n = await depth(x + dx, y + dy);
          if (n === null || Math.abs(n - z) > 0.03 * z) { flat = false; break; }
        }
        if (flat) points.push({x, y, z});
      }
    return points;
  }, w, h, d);
}

async function main() {
  // The browser is started first, so the time to the first preview is the command's and the
  // page's, as for a user whose browser is already open.
  const browser = await puppeteer.launch({
    executablePath: chromium, headless: true,
    args: ["--no-sandbox", "--disable-gpu", "--window-size=1200,800"],
  });
  let server;
  const results = {width};
  try {
    const page = await browser.newPage();
    await page.setViewport({width: 1200, height: 800});
    const pageErrors = [];
    page.on("pageerror", (e) => pageErrors.push(String(e)));
    server = await startServer();
    results.command_to_address_ms = Date.now() - server.started;

    // Load: the first preview appears.
    await page.goto(server.url);
    await page.waitForFunction(() => window.dofcacheView.previewDrawn > 0,
                               {timeout: 30000, polling: 10});
    results.first_preview_on_page_ms = Date.now() - server.started;
    const status = await page.evaluate(() => window.dofcacheView.status);
    // Without the token the server refuses the page.
    const other = await browser.newPage();
    const refused = await other.goto(server.url.replace(/\?token=.*/, ""));
    check(refused.status() === 401, "the page without the token is refused (401)");
    await other.close();
    results.first_preview_server_ms = status.first_preview_ms;
    check(true, `first preview on the page ${results.first_preview_on_page_ms} ms after the ` +
          `command started (inputs ready after ${status.first_preview_ms.toFixed(0)} ms)`);
    await page.select("#show", "preview");

    // A near and a far object: flat regions at the smallest and largest depth.
    const w = status.width, h = status.height;
    const grid = Math.max(12, Math.round(w / 27));  // about 500 probes at any size
    const points = await flatPoints(page, w, h, grid);
    check(points.length >= 2, `found ${points.length} flat regions to click`);
    points.sort((a, b) => a.z - b.z);
    // The far object: the farthest in front of the backdrop. A plain wall shows no sharpness
    // either way once the render's noise is gone, so the backdrop's plane (the farthest 3 %) is
    // left out while anything else is there.
    const zmax = points[points.length - 1].z;
    const objects = points.filter((p) => p.z < 0.97 * zmax);
    const near = points[0], far = (objects.length > 1 ? objects : points).slice(-1)[0];
    check(far.z > 1.3 * near.z, `near object at ${near.z.toFixed(2)} m, far at ${far.z.toFixed(2)} m`);
    const canvas = await page.$("#main");
    const box = await canvas.boundingBox();
    const click = async (p) => {
      const before = await page.evaluate(() => window.dofcacheView.changes);
      await page.mouse.click(box.x + (p.x + 0.5) * box.width / w, box.y + (p.y + 0.5) * box.height / h);
      await waitForChange(page, before);
      return page.evaluate(() => window.dofcacheView.lens);
    };
    const r = Math.round(grid / 2);
    // Wait for the refined inputs, so the noise level does not change between the two clicks.
    await page.waitForFunction(() => window.dofcacheView.status &&
                               window.dofcacheView.status.stage === "refined" &&
                               window.dofcacheView.drawnInputsVersion === window.dofcacheView.status.inputs_version,
                               {timeout: 120000, polling: 100});
    const latencies = [];
    let lens = await click(near);
    latencies.push(await page.evaluate(() => window.dofcacheView.lastLatencyMs));
    check(Math.abs(lens.focus_distance - near.z) < 1e-3 * near.z,
          `click on the near object focuses at its depth (${lens.focus_distance.toFixed(3)} m)`);
    const nearFocused = {near: await sharpness(page, near.x, near.y, r),
                         far: await sharpness(page, far.x, far.y, r)};
    lens = await click(far);
    latencies.push(await page.evaluate(() => window.dofcacheView.lastLatencyMs));
    check(Math.abs(lens.focus_distance - far.z) < 1e-3 * far.z,
          `click on the far object focuses at its depth (${lens.focus_distance.toFixed(3)} m)`);
    const farFocused = {near: await sharpness(page, near.x, near.y, r),
                        far: await sharpness(page, far.x, far.y, r)};
    results.sharpness = {nearFocused, farFocused};
    check(nearFocused.near > 1.5 * farFocused.near,
          `near region sharp when clicked (${nearFocused.near.toFixed(1)}), blurred when the far ` +
          `one is (${farFocused.near.toFixed(1)})`);
    check(farFocused.far > 1.5 * nearFocused.far,
          `far region sharp when clicked (${farFocused.far.toFixed(1)}), blurred when the near ` +
          `one is (${nearFocused.far.toFixed(1)})`);
    for (let i = 0; i < 4; ++i) {  // a few more clicks for the latency figure
      await click(i % 2 ? far : near);
      latencies.push(await page.evaluate(() => window.dofcacheView.lastLatencyMs));
    }
    results.click_to_image_ms = latencies;
    check(true, `click to image: ${latencies.map((l) => l.toFixed(0)).join(", ")} ms`);

    // The f-number: stopping down brings the near (out of focus) region back towards sharp.
    const before = await page.evaluate(() => window.dofcacheView.changes);
    await page.$eval("#fstop", (el) => { el.value = 1000; el.dispatchEvent(new Event("change")); });
    await waitForChange(page, before);
    lens = await page.evaluate(() => window.dofcacheView.lens);
    check(lens.fstop > 30, `f-number slider sets f/${lens.fstop.toFixed(1)}`);
    const stoppedDown = await sharpness(page, near.x, near.y, r);
    check(stoppedDown > farFocused.near,
          `stopped down, the out-of-focus region is sharper (${stoppedDown.toFixed(1)} > ` +
          `${farFocused.near.toFixed(1)})`);

    // The reference refines in the background; the comparison shows the error.
    await page.select("#show", "wipe");
    await page.waitForFunction(() => window.dofcacheView.status.reference.spp > 0 &&
                               window.dofcacheView.status.lens.fstop > 30 &&
                               window.dofcacheView.relMse !== null, {timeout: 240000, polling: 200});
    results.reference_first_pass_s = await page.evaluate(() => window.dofcacheView.status.reference.seconds);
    results.rel_mse = await page.evaluate(() => window.dofcacheView.relMse);
    results.reference_spp = await page.evaluate(() => window.dofcacheView.status.reference.spp);
    check(results.rel_mse > 0 && results.rel_mse < 1,
          `reference drawn (${results.reference_spp} spp), relMSE to the preview ${results.rel_mse.toFixed(4)}`);

    // Save: the page downloads the PNG the server makes in memory.
    const downloads = path.join(outDir, "downloads");
    fs.rmSync(downloads, {recursive: true, force: true});
    fs.mkdirSync(downloads, {recursive: true});
    const cdp = await page.createCDPSession();
    await cdp.send("Browser.setDownloadBehavior", {behavior: "allow", downloadPath: downloads});
    await page.click("#save");
    let saved = null;
    for (let i = 0; i < 100 && !saved; ++i) {
      await sleep(100);
      saved = fs.readdirSync(downloads).find((f) => f.endsWith(".png"));
    }
    check(!!saved, "Save PNG downloads " + saved);
    const bytes = fs.readFileSync(path.join(downloads, saved));
    check(bytes.slice(1, 4).toString() === "PNG", "the saved file is a PNG");
    await page.click("#save-exr");
    let exr = null;
    for (let i = 0; i < 100 && !exr; ++i) {
      await sleep(100);
      exr = fs.readdirSync(downloads).find((f) => f.endsWith(".exr"));
    }
    check(!!exr && fs.readFileSync(path.join(downloads, exr)).readUInt32LE(0) === 20000630,
          "Save EXR downloads an OpenEXR file " + exr);

    await page.click("#copy");
    await page.waitForFunction(() => document.getElementById("lens-text").value.length > 0);
    const text = await page.$eval("#lens-text", (el) => el.value);
    check(JSON.parse(text).extras.lens.fstop === lens.fstop, "copy lens gives extras.lens " + text);

    // The camera dollied in with the + key: new inputs are rendered and drawn.
    const inputsBefore = await page.evaluate(() => window.dofcacheView.drawnInputsVersion);
    await page.keyboard.press("+");
    await page.waitForFunction(() => window.dofcacheView.cameraVersion === 1);
    await page.waitForFunction((v) => window.dofcacheView.drawnInputsVersion > v, {}, inputsBefore);
    check(true, "the + key dollies the camera and the preview is drawn again");

    // Two keys appended to the keyframe file given on the command line, the second with the lens
    // of the moment.
    const keyframes = path.join(outDir, "keyframes.json");
    await page.click("#keyframe");
    await page.waitForFunction(() => window.dofcacheView.keyframes === 1);
    await page.click("#keyframe");
    await page.waitForFunction(() => window.dofcacheView.keyframes === 2);
    const keys = JSON.parse(fs.readFileSync(keyframes, "utf8")).keys;
    check(keys.length === 2 && keys[1].fstop === lens.fstop && keys[1].frame === 24,
          "Append keyframe writes the lens as keys of " + keyframes);

    // A shipped lens from the menu: its prescription sets the focal length (the field is
    // disabled), the field of view is shown, and the inputs are seen again through it.
    const inputsThin = await page.evaluate(() => window.dofcacheView.drawnInputsVersion);
    const lensChanges = await page.evaluate(() => window.dofcacheView.changes);
    await page.select("#lens", "double_gauss_50mm");
    await waitForChange(page, lensChanges);
    const real = await page.evaluate(() => window.dofcacheView.lens);
    check(real.lens_file === "double_gauss_50mm" && Math.abs(real.focal_length - 0.0504) < 2e-4,
          `the lens menu mounts the double Gauss (${(real.focal_length * 1000).toFixed(1)} mm)`);
    check(await page.$eval("#focal", (el) => el.disabled), "its focal length field is disabled");
    await page.waitForFunction((v) => window.dofcacheView.drawnInputsVersion > v &&
                               document.getElementById("fov").textContent.includes(" x "),
                               {timeout: 120000}, inputsThin);
    check(true, "the inputs are drawn through it, field of view " +
          (await page.$eval("#fov", (el) => el.textContent)) + " degrees");
    const thinChanges = await page.evaluate(() => window.dofcacheView.changes);
    await page.select("#lens", "");
    await waitForChange(page, thinChanges);
    check((await page.evaluate(() => window.dofcacheView.lens)).lens_file === null &&
          !(await page.$eval("#focal", (el) => el.disabled)), "the thin lens again");

    // Back to the occlusion-fixed preview focused on the near object, wide open, for the
    // screenshot in docs/view.md.
    await page.$eval("#fstop", (el) => { el.value = 300; el.dispatchEvent(new Event("change")); });
    await click(near);
    await sleep(600);
    await page.screenshot({path: path.join(outDir, "view.png")});
    check(pageErrors.length === 0, "no script errors on the page " + pageErrors.join("; "));
    const errors = await page.evaluate(() => window.dofcacheView.errorMessages);
    check(errors.length === 0, "no errors shown on the page " + errors.join("; "));
    results.memory_bytes = await page.evaluate(() => window.dofcacheView.status.memory_bytes);
  } finally {
    await browser.close();
    if (server) server.child.kill("SIGTERM");
  }
  fs.writeFileSync(path.join(outDir, "browser_test.json"), JSON.stringify(results, null, 2) + "\n");
  // The server must stop cleanly on SIGTERM.
  const code = await new Promise((resolve) => {
    if (server.child.exitCode !== null) return resolve(server.child.exitCode);
    server.child.on("exit", (c) => resolve(c));
  });
  check(code === 0, "dofcache view stops on SIGTERM with status 0");
}

main().then(() => { console.log("PASSED"); process.exit(0); },
            (e) => { console.error("browser test: " + e.message); process.exit(1); });
