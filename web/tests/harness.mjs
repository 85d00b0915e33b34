// The page in headless Debian Chromium for the browser tests (browser.mjs, browser_splats.mjs): the site served
// on a free port with the test's own files beside it (`extra`), puppeteer-core driving /usr/bin/chromium
// (nothing is downloaded; exit 77, skipped, where it is not installed), the page's errors collected.
import { existsSync, readFileSync } from 'node:fs';
import { createServer } from 'node:http';
import { join, extname, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

export async function startPage(siteArg) {
  const site = resolve(siteArg);
  const chromium = process.env.MLSDEFORM_CHROMIUM ?? '/usr/bin/chromium';
  if (!existsSync(chromium)) {
    console.log(`skipped: ${chromium} is not installed (tools/install_deps.sh web installs Chromium)`);
    process.exit(77);
  }
  const require = createRequire(join(dirname(fileURLToPath(import.meta.url)), '..', 'package.json'));
  const puppeteer = require('puppeteer-core');

  const types = { '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.wasm': 'application/wasm', '.json': 'application/json' };
  const extra = new Map();  // path -> bytes, served beside the site (the test's files)
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    if (extra.has(path)) return res.end(extra.get(path));
    const file = join(site, path === '/' ? 'index.html' : path);
    if (!file.startsWith(site) || !existsSync(file)) {
      if (process.env.MLSDEFORM_WEB_DEBUG) console.error('404 ' + path);
      res.statusCode = 404;
      return res.end();
    }
    res.setHeader('Content-Type', types[extname(file)] ?? 'application/octet-stream');
    res.end(readFileSync(file));
  });
  await new Promise((r) => server.listen(0, '127.0.0.1', r));
  const base = `http://127.0.0.1:${server.address().port}/`;

  const browser = await puppeteer.launch({
    executablePath: chromium,
    headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--window-size=800,600'],
  });
  let failed = false;
  const fail = (message) => {
    console.error('FAILED: ' + message);
    failed = true;
  };
  const page = await browser.newPage();
  await page.setViewport({ width: 800, height: 600 });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => m.type() === 'error' && errors.push(m.text()));
  /** Opens the page with the query (e.g. '?mesh=x.ply') and waits for what it names to be loaded. */
  const open = async (query) => {
    await page.goto(base + query);
    try {
      await page.waitForFunction(() => window.mlsdeformPage, { timeout: 20000 });
    } catch {
      throw new Error('the page did not start: ' + errors.join(' | '));
    }
    await page.evaluate(() => window.mlsdeformPage.ready);
  };
  /** Fails on errors the page reported, closes the browser and the server, and exits (1 if anything failed). */
  const finish = async () => {
    if (errors.length) fail('page errors: ' + errors.join(' | '));
    await browser.close();
    server.close();
    process.exit(failed ? 1 : 0);
  };
  return { site, base, browser, page, open, extra, errors, fail, finish };
}

// The share of the canvas's pixels that differ from the page's background colour (#20242a) by more than a
// little: what the screenshot tests call "not blank".
export function litShare(page) {
  return page.evaluate(() => {
    const c = document.querySelector('#view canvas');
    const g = document.createElement('canvas');
    g.width = c.width, g.height = c.height;
    const ctx = g.getContext('2d');
    ctx.drawImage(c, 0, 0);
    const d = ctx.getImageData(0, 0, g.width, g.height).data;
    let on = 0;
    for (let i = 0; i < d.length; i += 4) on += Math.abs(d[i] - 0x20) + Math.abs(d[i + 1] - 0x24) + Math.abs(d[i + 2] - 0x2a) > 30;
    return on / (d.length / 4);
  });
}
