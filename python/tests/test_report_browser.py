"""The report's index.html opened in a real browser (Debian's headless Chromium): it loads, every
image is found and decodes, and no console error or warning appears.

The browser is driven over the DevTools protocol on a pipe (--remote-debugging-pipe: JSON
messages ending in NUL, written to the browser's fd 3 and read from its fd 4), so nothing but
the standard library is needed. The events that count as problems:
  Runtime.consoleAPICalled of type error, warning or assert (console.error(), console.warn(), ...),
  Runtime.exceptionThrown (an uncaught script error),
  Log.entryAdded of level error or warning (the browser's own messages, e.g. "Failed to load
  resource: net::ERR_FILE_NOT_FOUND" for an image that is missing).
After the load event every <img> must be complete with naturalWidth > 0 (found and decoded).
Skipped when no Chromium is installed (scripts/setup.sh installs chromium-headless-shell), except
under scripts/test.sh (CDSHEAR_REQUIRE_BROWSER=1), where that fails."""
import fcntl
import json
import os
import select
import shutil
import signal
import tempfile
import time
import unittest

from tests import test_report
from tests.test_report import main

CHROMIUM = next(filter(None, map(shutil.which, ("chromium-headless-shell", "chromium"))), None)
TIMEOUT = 60.0   # seconds for one page, start to close (the CI machine may be busy)


class Browser:
    """Headless Chromium with a temporary profile, spoken to over --remote-debugging-pipe."""

    def __init__(self, exe, timeout=TIMEOUT):
        self.deadline = time.monotonic() + timeout
        self.tmp = tempfile.TemporaryDirectory()
        fds = os.pipe() + os.pipe()
        # above 10, so that moving them to 3 and 4 in the child cannot overwrite one another
        to_browser_r, self.w, self.r, from_browser_w = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
                                                        for fd in fds]
        for fd in fds:
            os.close(fd)
        self.stderr = os.path.join(self.tmp.name, "stderr.txt")
        args = [exe, "--headless", "--no-sandbox", "--no-first-run", "--remote-debugging-pipe",
                f"--user-data-dir={os.path.join(self.tmp.name, 'profile')}", "about:blank"]
        self.pid = os.posix_spawn(exe, args, os.environ, file_actions=[
            (os.POSIX_SPAWN_OPEN, 0, os.devnull, os.O_RDONLY, 0),
            (os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0),
            (os.POSIX_SPAWN_OPEN, 2, self.stderr, os.O_WRONLY | os.O_CREAT, 0o600),
            (os.POSIX_SPAWN_DUP2, to_browser_r, 3), (os.POSIX_SPAWN_DUP2, from_browser_w, 4)])
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.buf, self.last_id, self.events = b"", 0, []

    def send(self, method, params=None, session=None):
        """The result of one command; events read meanwhile are kept in self.events."""
        self.last_id += 1
        msg = {"id": self.last_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.w, json.dumps(msg).encode() + b"\0")
        while True:
            m = self.read()
            if m is None:
                raise TimeoutError(f"{method}: no answer from the browser\n{self.log_tail()}")
            if m.get("id") == self.last_id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m["result"]

    def read(self, until=None):
        """The next message, or None at `until` (monotonic time) or the deadline."""
        until = self.deadline if until is None else min(until, self.deadline)
        while b"\0" not in self.buf:
            left = until - time.monotonic()
            if left <= 0 or not select.select([self.r], [], [], left)[0]:
                return None
            chunk = os.read(self.r, 1 << 16)
            if not chunk:
                raise RuntimeError(f"the browser closed the pipe\n{self.log_tail()}")
            self.buf += chunk
        text, self.buf = self.buf.split(b"\0", 1)
        m = json.loads(text)
        if "method" in m:
            self.events.append(m)
        return m

    def wait_event(self, method, session):
        while not any(e["method"] == method and e.get("sessionId") == session
                      for e in self.events):
            if self.read() is None:
                raise TimeoutError(f"no {method} from the browser\n{self.log_tail()}")

    def settle(self, seconds):
        """Reads the events that come within `seconds` (late console messages)."""
        until = time.monotonic() + seconds
        while self.read(until) is not None:
            pass

    def log_tail(self, lines=20):
        with open(self.stderr, errors="replace") as f:
            return "browser stderr:\n" + "".join(f.readlines()[-lines:])

    def close(self):
        try:
            os.write(self.w, json.dumps({"id": 0, "method": "Browser.close"}).encode() + b"\0")
        except OSError:
            pass
        for _ in range(100):
            if os.waitpid(self.pid, os.WNOHANG)[0]:
                break
            time.sleep(0.05)
        else:
            os.kill(self.pid, signal.SIGKILL)
            os.waitpid(self.pid, 0)
        os.close(self.w)
        os.close(self.r)
        self.tmp.cleanup()


PAGE_STATE = ("JSON.stringify({title: document.title, h1: document.querySelector('h1') ? "
              "document.querySelector('h1').textContent : null, images: [...document.images]"
              ".map(i => [i.getAttribute('src'), i.complete, i.naturalWidth])})")


def problem(event):
    """The text of a console or log event that is an error or a warning, else None."""
    p = event["params"]
    if event["method"] == "Runtime.consoleAPICalled" and p["type"] in ("error", "warning",
                                                                        "assert"):
        args = " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
        return f"console.{p['type']}: {args}"
    if event["method"] == "Runtime.exceptionThrown":
        d = p["exceptionDetails"]
        what = d.get("exception", {}).get("description", d["text"]).split("\n")[0]
        return (f"exception: {what} "
                f"({d.get('url', '')}:{d.get('lineNumber', 0) + 1})")
    if event["method"] == "Log.entryAdded" and p["entry"]["level"] in ("error", "warning"):
        e = p["entry"]
        return f"{e['level']} ({e['source']}): {e['text']} {e.get('url', '')}".rstrip()
    return None


def open_page(path, exe=CHROMIUM):
    """Opens the file `path` in headless Chromium; returns {"title", "h1", "images": [[src,
    complete, naturalWidth], ...], "problems": [text, ...]} where problems are a failed load,
    console errors and warnings, uncaught exceptions and the browser's error or warning log
    (e.g. a resource that failed to load)."""
    b = Browser(exe)
    try:
        target = b.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        s = b.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime", "Log"):
            b.send(f"{domain}.enable", session=s)
        b.events.clear()
        url = "file://" + os.path.abspath(path)
        nav = b.send("Page.navigate", {"url": url}, session=s)
        problems = [f"load failed: {nav['errorText']} {url}"] if nav.get("errorText") else []
        if not problems:
            b.wait_event("Page.loadEventFired", s)   # after every image loaded or failed
            b.settle(0.3)
        state = json.loads(b.send("Runtime.evaluate", {"expression": PAGE_STATE,
                                                       "returnByValue": True},
                                  session=s)["result"]["value"])
        b.settle(0.1)
        problems += [t for t in map(problem, b.events) if t]
        state["problems"] = problems
        return state
    finally:
        b.close()


# scripts/test.sh installs Chromium and sets CDSHEAR_REQUIRE_BROWSER=1: there a missing browser
# fails the test instead of skipping it.
REQUIRED = os.environ.get("CDSHEAR_REQUIRE_BROWSER") == "1"


@unittest.skipIf(CHROMIUM is None and not REQUIRED,
                 "no headless Chromium (chromium-headless-shell or chromium; scripts/setup.sh "
                 "installs it)")
class ReportBrowserTest(unittest.TestCase):
    def setUp(self):
        if CHROMIUM is None:
            self.fail("CDSHEAR_REQUIRE_BROWSER=1, but neither chromium-headless-shell nor "
                      "chromium is on PATH")
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name
        # two systems, 16 runs: every fit and figure (self.d is the campaign folder)
        test_report.ReportTest.power_law_campaign(self)
        self.assertEqual(main(["report", self.d]), 0)
        self.out = os.path.join(self.d, "report")
        self.index = os.path.join(self.out, "index.html")

    def tearDown(self):
        self.tmp.cleanup()

    def test_report_page_loads_with_every_image_and_no_console_error(self):
        page = open_page(self.index)
        self.assertEqual(page["problems"], [])
        self.assertEqual(page["title"], "Campaign test_campaign")
        self.assertEqual(page["h1"], "Campaign test_campaign")
        figures = sorted(os.listdir(os.path.join(self.out, "figures")))
        self.assertEqual(sorted(src for src, _, _ in page["images"]),
                         [f"figures/{f}" for f in figures])
        self.assertGreaterEqual(len(figures), 5)
        for src, complete, width in page["images"]:
            self.assertTrue(complete and width > 0, f"{src}: not shown")

    def test_checker_notices_a_missing_image_and_script_errors(self):
        # the checker can fail: the page with a figure gone, one that is not a PNG (found, so
        # no log entry, but not decoded) and a script that warns, logs an error and throws
        os.remove(os.path.join(self.out, "figures", "nu_I.png"))
        with open(os.path.join(self.out, "figures", "Z_I.png"), "w") as f:
            f.write("not a png")
        with open(self.index) as f:
            text = f.read()
        with open(self.index, "w") as f:
            f.write(text.replace("</body>", "<script>console.warn('w1'); console.error('e1'); "
                                             "no_such_function();</script></body>"))
        page = open_page(self.index)
        self.assertEqual([src for src, _, width in page["images"] if width == 0],
                         ["figures/nu_I.png", "figures/Z_I.png"])
        found = "\n".join(page["problems"])
        self.assertEqual(len(page["problems"]), 4, found)
        self.assertRegex(found, r"error \(network\): Failed to load resource: "
                                r"net::ERR_FILE_NOT_FOUND file://\S+/figures/nu_I\.png")
        self.assertIn("console.warning: w1", found)
        self.assertIn("console.error: e1", found)
        self.assertIn("exception: ReferenceError: no_such_function is not defined", found)
        # a page that is not there
        missing = open_page(os.path.join(self.out, "nothing.html"))
        self.assertRegex(missing["problems"][0], r"^load failed: net::ERR_FILE_NOT_FOUND")


if __name__ == "__main__":
    unittest.main()
