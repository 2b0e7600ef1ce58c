#!/usr/bin/python3
"""The shop-floor panel in a real browser: headless Chromium (Debian's `chromium`), driven by
Selenium through `chromium-driver`, against `machplan serve` on the simulator.

What it does, as an operator would, and what it asserts:
  1. the page opened without the token (and with a wrong one) shows the login banner, its
     API calls get 401, the live stream stays offline, and nothing looks live: the state says
     "not authorised" (not idle) and the E-STOP is disabled (OUT/panel_refused.png);
  2. opened with the printed URL (the token) while another client holds control, Load and Run
     are greyed out and say why next to them; it logs in, goes live, takes control, loads
     datasets/parts/triangle_45.ngc through the file picker with the bundled material file and
     material 2, runs it: the state goes to
     running and the DRO's position changes; while the torch cuts Hold is pressed and a
     screenshot of the page saved (OUT/panel_running.png); the state goes to held and the DRO to rest;
     Resume ends in done at 100 %, and the report box shows the run (completed, one hold,
     torch off) where it is seen, without scrolling;
  3. run again, E-STOP pressed mid-cut: the fault banner names the E-stop, the DRO's torch is
     off, and the server's status agrees (faulted, estop latched, torch off); Reset clears the
     banner; run again and Stop: the state says cancelled, no fault banner; an E-STOP pressed
     then shows the E-stop (not an older message) until Reset.

Every wait is bounded and waits for a state, not for a time. The server and the browser are
always stopped, whatever happens.

    panel_browser_test.py --machplan build/dev/cli/machplan --out build/dev/tests/browser
"""
import argparse
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By

PART = "datasets/parts/triangle_45.ngc"
MATERIALS = "datasets/materials/thermal_gantry_material.cfg"


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)
    print("ok:", what, flush=True)


def wait_until(pred, what, timeout_s=30.0, step_s=0.03):
    end = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < end:
        last = pred()
        if last:
            print("ok:", what, flush=True)
            return last
        time.sleep(step_s)
    raise Failure(f"timed out after {timeout_s} s waiting for: {what}")


def start_server(machplan, speed):
    proc = subprocess.Popen([machplan, "serve", "--port", "0", "--sim-speed", str(speed)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    end = time.monotonic() + 30
    out = ""
    while time.monotonic() < end:
        line = proc.stdout.readline()
        if not line:
            break
        out += line
        m = re.search(r"open the panel at (http://127\.0\.0\.1:(\d+)/\?token=([0-9a-f]{64}))", line)
        if m:
            return proc, m.group(1), int(m.group(2)), m.group(3)
    proc.kill()
    raise Failure(f"machplan serve printed no URL:\n{out}")


def stop_server(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def server_status(port, token):
    req = urllib.request.Request(f"http://127.0.0.1:{port}/api/status", headers={"Authorization": "Bearer " + token})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


def take_control_elsewhere(port, token):
    # Another operator's client (a second browser, a script) holds control.
    req = urllib.request.Request(f"http://127.0.0.1:{port}/api/control", data=b'{"take": true}', method="POST",
                                 headers={"Authorization": "Bearer " + token, "Content-Type": "application/json",
                                          "X-Machplan-Client": "another-operators-client"})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


def browser(profile_dir):
    o = webdriver.ChromeOptions()
    o.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    for a in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,900",
              "--force-device-scale-factor=1", "--no-first-run", "--disable-extensions", f"--user-data-dir={profile_dir}"]:
        o.add_argument(a)
    driver_path = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    d = webdriver.Chrome(service=Service(driver_path), options=o)
    d.set_page_load_timeout(30)
    d.set_script_timeout(30)
    return d


def text(d, id_):
    return d.find_element(By.ID, id_).text


def state(d):
    # The text itself: the header shows it upper-cased by CSS, which Selenium's .text applies.
    return d.find_element(By.ID, "state").get_attribute("textContent").strip()


def visible(d, id_):
    return "hidden" not in (d.find_element(By.ID, id_).get_attribute("class") or "").split()


def dro(d):
    try:
        return float(text(d, "dro-x")), float(text(d, "dro-y"))
    except ValueError:
        return None


def fetch_status_code(d):
    # The page's own origin, with whatever the browser holds (no token in the refused case).
    return d.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "fetch('/api/status', {credentials: 'same-origin'}).then(r => done(r.status)).catch(e => done(-1));")


def refused_without_token(d, out_dir, port):
    for url in [f"http://127.0.0.1:{port}/", f"http://127.0.0.1:{port}/?token={'0' * 64}"]:
        d.get(url)
        wait_until(lambda: visible(d, "login"), f"{url.split('?')[-1] if '?' in url else 'no token'}: the login banner shows")
        check(fetch_status_code(d) == 401, "the API answers the page 401 without the token")
        time.sleep(0.5)  # a live stream, were it wrongly accepted, would be up by now
        check(text(d, "link") == "offline", "the live stream stays offline without the token")
        check(text(d, "machine") == "-", "nothing of the machine is shown")
        check(state(d) == "not authorised", f"the state says the page is not authorised (not idle): {state(d)!r}")
        check(not d.find_element(By.ID, "estop").is_enabled(), "the E-STOP is disabled: it could stop nothing from here")
    d.save_screenshot(os.path.join(out_dir, "panel_refused.png"))


def seen(d, id_):
    # The element lies within the window and within its scrolling panel's visible part.
    return d.execute_script(
        "const r = document.getElementById(arguments[0]).getBoundingClientRect();"
        "const a = document.querySelector('aside').getBoundingClientRect();"
        "return r.height > 0 && r.top >= a.top && r.bottom <= a.bottom && r.bottom <= window.innerHeight;", id_)


def why(d):
    return [e.text for e in d.find_elements(By.CSS_SELECTOR, ".why") if e.is_displayed()]


def run_job(d, out_dir, port, token):
    wait_until(lambda: not visible(d, "login"), "logged in from the printed URL")
    # The page drops the token from the address once its login answered; the login form may be
    # hidden before the page's script ran at all, so this is waited for, not read at once.
    wait_until(lambda: "token" not in d.current_url, "the token left the address bar")
    wait_until(lambda: text(d, "link") == "live", "the live stream is up")
    wait_until(lambda: "thermal_gantry" in text(d, "machine"), "the machine is named")
    check(d.find_element(By.ID, "estop").is_enabled() and state(d) == "idle", "connected: the E-STOP is live, the state idle")
    # Another client holds control: Load and Run are greyed out and say why, next to them.
    wait_until(lambda: not d.find_element(By.ID, "load").is_enabled() and not d.find_element(By.ID, "run").is_enabled(),
               "Load and Run are greyed out")
    hints = wait_until(lambda: (lambda w: w if len(w) == 2 and all("Another client has control" in h for h in w) else None)(why(d)),
                       "beside Load and beside Run: another client has control")
    check(all("Take control" in h for h in hints), f"the hint says what to do: {hints[0]!r}")
    d.save_screenshot(os.path.join(out_dir, "panel_control_elsewhere.png"))
    d.find_element(By.ID, "control").click()
    wait_until(lambda: text(d, "control") == "You have control", "control taken")
    wait_until(lambda: not why(d) and d.find_element(By.ID, "load").is_enabled(), "with control: Load is live, no hint")
    # The file picker: the program's text goes up with its name.
    d.find_element(By.ID, "file").send_keys(os.path.abspath(PART))
    # With a QtPlasmaC material file through its picker, and material 2 in force.
    d.find_element(By.ID, "materials").send_keys(os.path.abspath(MATERIALS))
    d.find_element(By.ID, "material").send_keys("2")
    d.find_element(By.ID, "load").click()
    wait_until(lambda: "triangle_45.ngc" in text(d, "job-info"), "the job is loaded and drawn")
    parts = d.execute_script("return view.job ? view.job.parts.length : 0")
    check(parts == 1, "one part drawn")
    start = wait_until(lambda: dro(d), "the DRO shows the position")
    d.find_element(By.ID, "run").click()
    wait_until(lambda: state(d) == "running", "the state is running")
    wait_until(lambda: dro(d) and dro(d) != start, "the DRO's position changes")
    wait_until(lambda: text(d, "dro-torch") == "ON arc", "the torch cuts")
    # Some of the cut on screen, then the picture of the running page.
    at = dro(d)
    wait_until(lambda: dro(d) and abs(dro(d)[0] - at[0]) + abs(dro(d)[1] - at[1]) > 15, "the tool moved 15 mm along the cut")
    check(int(text(d, "dro-line")) >= 9, "the DRO shows the program line of the cut")
    # Hold at once (the cut lasts about 4 s of wall clock; a screenshot on a loaded machine can
    # take one or two), then the picture of the page as the tool stops on the cut.
    d.find_element(By.ID, "hold").click()
    shot = os.path.join(out_dir, "panel_running.png")
    check(d.save_screenshot(shot) and os.path.getsize(shot) > 10000, f"screenshot saved: {shot}")
    wait_until(lambda: state(d) == "held", "Hold: the state is held", timeout_s=20)
    wait_until(lambda: float(text(d, "dro-feed")) == 0.0, "held: the feed is zero")
    # The setpoint has stopped; the tool settles onto it (the servo creeps the last hundredths), then stays.
    def settled():
        a = dro(d)
        time.sleep(0.25)
        b = dro(d)
        return a and b and max(abs(a[0] - b[0]), abs(a[1] - b[1])) < 0.05 and b

    a = wait_until(settled, "held: the DRO comes to rest", timeout_s=20)
    time.sleep(1.0)
    b = dro(d)
    check(max(abs(a[0] - b[0]), abs(a[1] - b[1])) < 0.1, f"held: the tool stays (within 0.1 mm, against 160 mm a second at the feed) at {a} (now {b})")
    d.save_screenshot(os.path.join(out_dir, "panel_held.png"))
    d.find_element(By.ID, "resume").click()
    wait_until(lambda: state(d) in ("running", "done"), "Resume: it runs on")
    wait_until(lambda: state(d) == "done", "the job is done", timeout_s=60)
    wait_until(lambda: text(d, "progress-text") == "100 %", "a completed run shows 100 %")
    wait_until(lambda: visible(d, "report-box") and text(d, "report-summary"), "the report shows")
    check(seen(d, "report-summary"), "the report is where it is seen, without scrolling")
    summary = text(d, "report-summary")
    check(summary.startswith("done: triangle_45.ngc"), f"the report says done: {summary.splitlines()[0]}")
    check("holds 1," in summary and "torch off at the end: yes" in summary, "the report counts the hold, torch off at the end")
    report = json.loads(d.execute_script("return document.getElementById('report-json').textContent"))
    check(report["summary"]["status"] == "done" and len(report["holds"]) == 1 and report["holds"][0]["in_cut"],
          f"the report's JSON: done, one hold, in the cut: {report['summary']['status']}, holds {report['holds']}")
    check([m["number"] for m in report["materials"]] == [2] and all(c["material"] == 0 for c in report["cuts"]),
          "the report's JSON: every cut in material 2 of the uploaded file")
    d.save_screenshot(os.path.join(out_dir, "panel_done.png"))
    s = server_status(port, token)
    check(s["state"] == "done", "the server agrees: done")


def estop_mid_cut(d, out_dir, port, token):
    d.find_element(By.ID, "run").click()
    wait_until(lambda: state(d) == "running", "run again: running")
    wait_until(lambda: text(d, "dro-torch") == "ON arc" and float(text(d, "dro-feed")) > 10, "the torch cuts again, moving",
               timeout_s=60)
    d.find_element(By.ID, "estop").click()
    wait_until(lambda: visible(d, "fault") and "estop" in text(d, "fault"), "E-STOP: the fault banner names it")
    wait_until(lambda: text(d, "dro-torch") == "off", "E-STOP: the torch is off on the DRO")
    d.save_screenshot(os.path.join(out_dir, "panel_estop.png"))
    s = wait_until(lambda: (lambda s: s if s["activity"] == "idle" else None)(server_status(port, token)),
                   "the machine is at rest")
    check(s["state"] == "faulted" and s["estop"] and not s["torch"]["fire"], "the server: faulted, E-stop latched, torch off")
    check(s["faults"][0]["kind"] == "estop", "the server's fault is the E-stop")
    d.find_element(By.ID, "reset").click()
    wait_until(lambda: not visible(d, "fault"), "Reset: the fault banner clears")


def stopped_then_estop(d, out_dir, port, token):
    d.find_element(By.ID, "run").click()
    wait_until(lambda: state(d) == "running", "run a third time: running")
    d.find_element(By.ID, "stop").click()
    wait_until(lambda: state(d) == "cancelled", "Stop: the state says cancelled, as the run ended")
    check(server_status(port, token)["state"] == "cancelled", "the server agrees: cancelled")
    time.sleep(1.0)  # two status polls: a banner, were one shown, would be up by now
    check(not visible(d, "fault"), "a stop asked for is no fault: no banner")
    d.find_element(By.ID, "estop").click()
    wait_until(lambda: visible(d, "fault") and text(d, "fault").startswith("E-STOP latched"),
               "E-STOP while idle: the banner shows the E-stop, the current fault")
    d.save_screenshot(os.path.join(out_dir, "panel_estop_idle.png"))
    d.find_element(By.ID, "reset").click()
    wait_until(lambda: not visible(d, "fault"), "Reset: the banner clears")


def jog_and_take(d, port, token, direction, point):
    # Hold a jog button as an operator does (the page repeats the stick every 100 ms), let go,
    # wait for rest, then take the position as an edge point.
    button = d.find_element(By.CSS_SELECTOR, f'.jog button[data-j="{direction}"]')
    ActionChains(d).click_and_hold(button).pause(1.2).release().perform()
    wait_until(lambda: server_status(port, token)["activity"] == "idle", f"jog {direction}: the machine comes to rest")
    time.sleep(0.5)  # a live frame or two at rest
    at = dro(d)
    d.find_element(By.ID, f"edge-{point}").click()
    shown = text(d, f"edge-{point}-at")
    check(shown == f"{at[0]:.3f}, {at[1]:.3f}", f"edge point {point} taken where the DRO stands: {shown} (DRO {at})")
    return at


def align_by_jogging(d, out_dir, port, token):
    first = jog_and_take(d, port, token, "1,0", 1)
    second = jog_and_take(d, port, token, "1,1", 2)
    d.find_element(By.ID, "load").click()
    msg = wait_until(lambda: (lambda m: m if "aligned to the sheet's edge" in m else None)(text(d, "message")),
                     "the job loads aligned to the sheet's edge")
    turned = float(re.search(r"turned (-?[0-9.]+) deg", msg).group(1))
    expect = math.degrees(math.atan2(second[1] - first[1], second[0] - first[0]))
    check(abs(turned - expect) < 0.01 and 30 < turned < 60, f"turned by the edge's angle: {turned} deg against {expect:.3f}")
    d.save_screenshot(os.path.join(out_dir, "panel_aligned.png"))
    # The aligned job framed by the laser pointer: the box beside Frame.
    d.find_element(By.ID, "frame-laser").click()
    d.find_element(By.ID, "frame").click()
    wait_until(lambda: "traced by the laser pointer" in text(d, "message"), "Frame with the laser box: the page says so")
    wait_until(lambda: server_status(port, token)["activity"] == "idle" and state(d) == "done", "the laser frame ends done",
               timeout_s=60)
    report = json.loads(urllib.request.urlopen(urllib.request.Request(
        f"http://127.0.0.1:{port}/api/report", headers={"Authorization": f"Bearer {token}"}), timeout=10).read())
    check(report["frame"]["pointer_offset_mm"] == [60.0, 0.0] and report["torch_on_s"] == 0.0,
          f"the report: a frame traced by the laser (offset {report['frame'].get('pointer_offset_mm')}), torch never on")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--machplan", required=True)
    ap.add_argument("--out", required=True, help="folder for the screenshots")
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    t0 = time.monotonic()
    proc, url, port, token = start_server(a.machplan, a.speed)
    profile = tempfile.mkdtemp(prefix="machplan-browser-")
    d = None
    try:
        d = browser(profile)
        refused_without_token(d, a.out, port)
        take_control_elsewhere(port, token)
        d.get(url)
        run_job(d, a.out, port, token)
        estop_mid_cut(d, a.out, port, token)
        stopped_then_estop(d, a.out, port, token)
        align_by_jogging(d, a.out, port, token)
        logs = [e for e in d.get_log("browser") if e.get("level") == "SEVERE" and "401" not in e.get("message", "")]
        check(not logs, f"no errors in the page's console: {logs[:3]}")
    except Failure as e:
        print("FAILED:", e, flush=True)
        if d:
            try:
                d.save_screenshot(os.path.join(a.out, "panel_failure.png"))
            except Exception:
                pass
        return 1
    finally:
        if d:
            d.quit()
        rc = stop_server(proc)
        shutil.rmtree(profile, ignore_errors=True)
        print(f"browser test: {time.monotonic() - t0:.1f} s; server exit {rc}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
