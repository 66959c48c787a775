// The live viewer in a real browser (issue #15, label browser). Starts the emulated rig with the viewer,
// opens the page in Debian's chromium (headless, playwright-core), and checks: live data arrives, the
// skeleton has its 15 joints, the 3D canvas is not blank, the node panel shows every node, recording
// from the page makes a session that the page lists, the session replays (play/pause/step), and, with
// three WebSocket clients connected — two pages and one that never reads — the rig completes every
// frame (none dropped, merging never stopped) while the viewer drops the stalled client's oldest
// messages and the host's memory stays bounded. Then `voxcap view SESSION` serves the recorded session
// alone (replayed the same way), and refuses a folder that is no session or holds no frames (exit 2, one
// line) and reads past a damaged record. Screenshots go to --out. Prints "N passed, N failed".
import { spawn, spawnSync } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import net from 'node:net';
import path from 'node:path';

const arg = (k, d) => { const i = process.argv.indexOf(k); return i > 0 ? process.argv[i + 1] : d; };
const voxcap = path.resolve(arg('--voxcap')), web = path.resolve(arg('--web')), out = path.resolve(arg('--out', 'artifacts'));
const { chromium } = createRequire(path.join(web, 'package.json'))('playwright-core');
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });
const work = path.join(out, 'run');
fs.mkdirSync(work);

let passed = 0, failed = 0;
const check = (ok, what) => { if (ok) passed++; else failed++; console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); };

// The rig: 3 nodes, the viewer on a free port; recordings go to ./recordings of the work folder.
const rig = spawn(voxcap, ['rig', '--emulated', '--view', '--view-port', '0', '--seconds', '900', '--nodes', '3',
                           '--size', '320x240', '--rate', '15', '--json'], { cwd: work });
let stdout = '';
rig.stdout.on('data', (d) => { stdout += d; });
rig.stderr.on('data', (d) => fs.appendFileSync(path.join(out, 'rig.stderr.txt'), d));
const rigExit = new Promise((resolve) => rig.on('exit', (code) => resolve(code)));
const until = async (fn, ms, what) => {
  const end = Date.now() + ms;
  while (Date.now() < end) { const v = await fn(); if (v) return v; await new Promise((r) => setTimeout(r, 250)); }
  throw new Error(`timed out waiting for ${what}`);
};

// A click as the page's handler sees it; playwright's own waits for a quiet page, which a page
// drawing 30 frames a second on a loaded machine may never be.
const click = (page, sel) => page.$eval(sel, (el) => el.click());

// Pixels of the 3D canvas that differ from the background, as a fraction.
const litFraction = (page) => page.evaluate(() => {
  const c = document.getElementById('canvas'), t = document.createElement('canvas');
  t.width = c.width; t.height = c.height;
  const g = t.getContext('2d'); g.drawImage(c, 0, 0);
  const d = g.getImageData(0, 0, t.width, t.height).data, [r, gg, b] = window.voxcap.background;
  let n = 0;
  for (let i = 0; i < d.length; i += 4) if (Math.abs(d[i] - r) + Math.abs(d[i + 1] - gg) + Math.abs(d[i + 2] - b) > 24) n++;
  return n / (d.length / 4);
});

// A page replaying a session: the timeline, play, pause, one step, the replayed frame drawn.
async function replaySteps(page, tag) {
  const rp = () => page.evaluate(() => window.voxcap.replay);
  await until(() => page.evaluate(() => window.voxcap.mode === 'replay' && window.voxcap.replay.loaded &&
    window.voxcap.replay.frames > 0 && !document.getElementById('timeline').hidden), 180000, `${tag}: the timeline`);
  const r0 = await rp();
  check(r0.frames > 30 && !r0.error, `${tag}: the timeline of ${r0.session} shows (${r0.frames} frames)`);
  await click(page, '#play');
  const a = (await rp()).index;
  const moved = await until(() => page.evaluate((i) => window.voxcap.replay.playing && window.voxcap.replay.index !== i &&
    window.voxcap.replay.index, a), 120000, `${tag}: playing`).catch(() => false);
  check(moved !== false, `${tag}: play moves the timeline (frame ${a + 1} → ${moved + 1})`);
  await click(page, '#pause');
  await until(() => page.evaluate(() => !window.voxcap.replay.playing), 60000, `${tag}: paused`);
  await new Promise((r) => setTimeout(r, 1000));
  const i0 = (await rp()).index;
  await new Promise((r) => setTimeout(r, 1000));
  check((await rp()).index === i0, `${tag}: pause holds the frame (${i0 + 1})`);
  const by = i0 + 1 < r0.frames ? 1 : -1;  // paused on the last frame: one back
  await click(page, by > 0 ? '#stepf' : '#stepb');
  await until(() => page.evaluate((i) => window.voxcap.replay.index !== i, i0), 60000, `${tag}: a step`);
  const r1 = await rp();
  const tpos = await page.$eval('#tpos', (el) => el.textContent);
  check(r1.index === i0 + by && !r1.playing && tpos.startsWith(`${i0 + by + 1} / ${r1.frames}`),
        `${tag}: a step moves exactly one frame (${i0 + 1} → ${r1.index + 1}: "${tpos}")`);
  // The replayed frame itself is drawn: the hull of the step's seq, then the canvas is not blank.
  await until(() => page.evaluate(() => window.voxcap.seq === window.voxcap.replay.seq && window.voxcap.rendered > 0), 60000,
              `${tag}: the replayed hull drawn`);
  await page.evaluate(() => new Promise((res) => requestAnimationFrame(() => requestAnimationFrame(res))));
  const lit = await litFraction(page);
  const j = await page.evaluate(() => window.voxcap.joints.length);
  check(lit > 0.01 && j === 15, `${tag}: the canvas shows the replayed hull (seq ${r1.seq}) and skeleton (${j} joints): ` +
        `${(100 * lit).toFixed(1)} % of pixels differ from the background`);
  await page.screenshot({ path: path.join(out, `${tag}.png`), timeout: 120000 });
}

let browser, stalled, session;
try {
  const url = await until(() => (stdout.match(/viewer: (http:\/\/127\.0\.0\.1:\d+\/)/) || [])[1], 120000, 'the viewer URL');
  console.log(`viewer at ${url}`);
  browser = await chromium.launch({ executablePath: '/usr/bin/chromium', headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'] });
  const page = await browser.newPage({ viewport: { width: 1400, height: 860 } });
  page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
  await page.goto(url);
  // A second page and a client that never reads: three WebSocket clients in all.
  const page2 = await browser.newPage();
  await page2.goto(url);
  const port = Number(new URL(url).port);
  stalled = net.connect(port, '127.0.0.1', () => {
    stalled.write(`GET /ws HTTP/1.1\r\nHost: 127.0.0.1:${port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n` +
                  'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n');
    stalled.pause();  // never reads again: its TCP window fills, then the server's queue for it
  });
  stalled.setRecvBufferSize?.(4096);

  // Live data: hulls, the pose with its joints, every node in the panel.
  await until(() => page.evaluate(() => window.voxcap.hulls > 5 && window.voxcap.joints.length > 0 && window.voxcap.nodes.length > 0), 240000, 'live hulls and a pose');
  const s = await page.evaluate(() => ({ joints: window.voxcap.joints, hello: window.voxcap.hello, rendered: window.voxcap.rendered,
    nodes: window.voxcap.nodes, rows: [...document.querySelectorAll('#nodes tbody tr')].map((r) => r.dataset.node) }));
  check(s.joints.length === 15 && s.joints.every((p) => p.length === 3 && p.every(Number.isFinite)), `the skeleton has 15 joints (${s.joints.length})`);
  check(s.rendered > 0, `the hull is drawn (${s.rendered} surface voxels)`);
  check(s.hello.nodes.length === 3 && s.hello.nodes.every((n) => s.rows.includes(n.id)), `the node panel shows every node (${s.rows.join(', ')})`);
  check(s.nodes.every((n) => n.connected), 'every node is connected');
  // The canvas is not blank: pixels that differ from the background.
  const lit = await litFraction(page);
  check(lit > 0.01, `the 3D view is not blank (${(100 * lit).toFixed(1)} % of pixels differ from the background)`);
  await until(() => page.evaluate(() => window.voxcap.silhouettes > 0), 60000, 'a silhouette preview').catch(() => {});
  check(await page.evaluate(() => window.voxcap.silhouettes > 0), 'the camera panels got silhouette previews');
  await page.screenshot({ path: path.join(out, 'live.png'), timeout: 120000 });

  // Record from the page: the indicator on, off again, and the session in the page's list.
  await click(page, '#record');
  await until(() => page.evaluate(() => document.getElementById('record').classList.contains('on') &&
                                          window.voxcap.recording.records > 30), 180000, 'the recording indicator on');
  check(true, `the page shows the recording on (${await page.evaluate(() => window.voxcap.recording.records)} records)`);
  await new Promise((r) => setTimeout(r, 10000));  // a session of some seconds to replay
  await click(page, '#record');
  session = await until(() => page.evaluate(() => !document.getElementById('record').classList.contains('on') &&
    [...document.querySelectorAll('#sessions option')].map((o) => o.textContent)[0]), 120000, 'the session in the page\'s list');
  check(fs.existsSync(path.join(work, 'recordings', session, 'records.vcr')), `recording from the page made ${session}, listed on the page`);

  // Replay it from the page.
  await page.$eval('#sessions', (el, v) => { el.value = v; }, session);
  await click(page, '#replay');
  await replaySteps(page, 'replay');
  await click(page, '#live');
  await until(() => page.evaluate(() => window.voxcap.mode === 'live' && document.getElementById('timeline').hidden), 60000, 'back to live');

  const viewer = await page.evaluate(() => window.voxcap.viewer);
  check(viewer.clients === 3, `three clients were connected (${viewer.clients})`);
  console.log(`viewer: ${viewer.dropped} messages of slow clients dropped, ${viewer.frames_skipped} frames skipped for the page`);
} catch (e) {
  check(false, e.message);
}
if (stalled) stalled.destroy();
for (const p of browser ? browser.contexts().flatMap((c) => c.pages()) : []) await p.close().catch(() => {});
rig.kill('SIGINT');
const code = await rigExit;
try {
  const j = JSON.parse(stdout.slice(stdout.indexOf('{')));
  fs.writeFileSync(path.join(out, 'rig.json'), JSON.stringify(j, null, 2));
  check(code === 0 && !j.merging_stopped && j.dropped === 0 && j.frames > 0,
        `the rig completed every frame with the viewer's clients (${j.frames} merged, ${j.dropped} dropped, exit ${code})`);
  const rss = (j.host_rss_kb.end - j.host_rss_kb.start) / 1024;
  check(rss < 768, `the host's memory stayed bounded (+${rss.toFixed(0)} MiB over the run)`);
} catch (e) {
  check(false, `the rig's JSON: ${e.message} (exit ${code})`);
}

// `voxcap view SESSION`: the recorded session alone, no rig; then sessions that are not right.
if (browser && session) {
  const dir = path.join(work, 'recordings', session);
  const view = spawn(voxcap, ['view', dir, '--view-port', '0'], { cwd: work });
  let vout = '';
  view.stdout.on('data', (d) => { vout += d; });
  view.stderr.on('data', (d) => fs.appendFileSync(path.join(out, 'view.stderr.txt'), d));
  const viewExit = new Promise((resolve) => view.on('exit', (code) => resolve(code)));
  try {
    const vurl = await until(() => (vout.match(/viewer: (http:\/\/127\.0\.0\.1:\d+\/)/) || [])[1], 60000, 'voxcap view\'s URL');
    console.log(`voxcap view at ${vurl}`);
    const vpage = await browser.newPage({ viewport: { width: 1400, height: 860 } });
    vpage.on('pageerror', (e) => console.log(`page error: ${e.message}`));
    await vpage.goto(vurl);
    await until(() => vpage.evaluate(() => window.voxcap.hello && window.voxcap.hello.mode === 'session'), 60000, 'the session\'s Hello');
    const solo = await vpage.evaluate(() => ({ rec: document.getElementById('record').hidden, live: document.getElementById('live').hidden,
                                               session: window.voxcap.hello.session }));
    check(solo.rec && solo.live && solo.session === session, `voxcap view serves ${solo.session} alone (no record, no live)`);
    await replaySteps(vpage, 'view');
  } catch (e) {
    check(false, `voxcap view: ${e.message}`);
  }
  view.kill('SIGINT');
  const vcode = await viewExit;
  check(vcode === 0, `voxcap view stops on SIGINT (exit ${vcode})`);

  const run = (args) => spawnSync(voxcap, args, { cwd: work, encoding: 'utf8', timeout: 120000 });
  const oneLine = (r) => r.stderr.trim().split('\n').length === 1;
  let r = run(['view', path.join(work, 'no-such-session'), '--view-port', '0']);
  check(r.status === 2 && oneLine(r), `voxcap view of no session: exit ${r.status}, "${r.stderr.trim()}"`);
  const zeros = path.join(work, 'zeros');
  fs.mkdirSync(zeros);
  for (const f of ['rig.toml', 'calibration.yaml', 'session.json']) fs.copyFileSync(path.join(dir, f), path.join(zeros, f));
  fs.writeFileSync(path.join(zeros, 'records.vcr'), Buffer.alloc(65536));
  r = run(['view', zeros, '--view-port', '0', '--seconds', '1']);
  check(r.status === 2 && oneLine(r), `voxcap view of a session of zeros: exit ${r.status}, "${r.stderr.trim()}"`);
  const damaged = path.join(work, 'damaged');
  fs.cpSync(dir, damaged, { recursive: true });
  const vcr = fs.readFileSync(path.join(damaged, 'records.vcr'));
  vcr.fill(0x55, vcr.length >> 1, (vcr.length >> 1) + 64);
  fs.writeFileSync(path.join(damaged, 'records.vcr'), vcr);
  r = run(['view', damaged, '--view-port', '0', '--seconds', '1']);
  check(r.status === 0 && /damaged records? skipped/.test(r.stdout) && /record \d+/.test(r.stderr),
        `voxcap view reads past a damaged record: exit ${r.status}, "${r.stdout.split('\n')[0]}", "${r.stderr.trim().split('\n')[0]}"`);
}
if (browser) await browser.close();
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
