#!/usr/bin/env python3
"""Opens orbcal's report.html files in a real headless browser (Debian's chromium) and checks that each
renders with every figure loaded, loads nothing from elsewhere, and prints to PDF.

  check_report.py --orbcal BIN --work DIR [--chromium PATH] [--screenshots DIR]
      makes one report of each kind with BIN in DIR (make_reports) and checks them
  check_report.py [--chromium PATH] [--screenshots DIR] REPORT.html ...
      checks the given reports

Each page is loaded from a copy with a probe script appended that, once the page has loaded, writes on
<body> how many <img> it has and which have no decoded pixels (naturalWidth 0); chromium --dump-dom
prints the DOM, which the probe's attributes are read from. Name resolution is switched off, so a page
that needed the network would show a broken image. Without chromium the check is skipped with a line
"orbcal-test-skipped: ..." (CTest's skip pattern, tests/CMakeLists.txt); exit 1 on any failure.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

PROBE = """<script>
window.addEventListener("load", () => {
  const images = Array.from(document.images);
  document.body.setAttribute("data-orbcal-images", String(images.length));
  document.body.setAttribute("data-orbcal-broken",
      images.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt || i.src.slice(0, 40)).join("|"));
  document.body.setAttribute("data-orbcal-loaded", "1");
});
</script>
"""


def chromium_command(chromium, profile):
    return [chromium, "--headless", "--disable-gpu", "--no-sandbox", "--no-first-run", "--user-data-dir=" + profile,
            "--host-resolver-rules=MAP * ~NOTFOUND", "--virtual-time-budget=10000"]


def outside_references(html):
    """src= and href= that would load or lead elsewhere than the page itself and its data: URIs."""
    refs = re.findall(r'(?:src|href)\s*=\s*"([^"]*)"', html)
    loads = [r for r in re.findall(r'src\s*=\s*"([^"]*)"', html) if not r.startswith("data:")]
    external = [r for r in refs if re.match(r"[a-z]+://", r)]
    tags = re.findall(r"<(?:link|script|iframe|object|embed)\b", html, flags=re.I)
    return list(dict.fromkeys(loads + external + tags))


def check(chromium, path, screenshot_dir, print_pdf=True, quiet=False):
    """Problems of one report.html, as lines; [] when it renders with every figure loaded."""
    with open(path, encoding="utf-8") as f:
        html = f.read()
    problems = ["loads or links outside the page: %s" % r for r in outside_references(html)]
    expected = html.count("<img ")
    with tempfile.TemporaryDirectory(prefix="orbcal-browser-") as tmp:
        probe_page = os.path.join(tmp, "probe.html")
        with open(probe_page, "w", encoding="utf-8") as f:
            f.write(html.replace("</body>", PROBE + "</body>"))
        run = subprocess.run(chromium_command(chromium, tmp + "/profile") + ["--dump-dom", "file://" + probe_page],
                             capture_output=True, text=True, timeout=120)
        body = re.search(r"<body[^>]*>", run.stdout)
        attrs = dict(re.findall(r'data-orbcal-(\w+)="([^"]*)"', body.group(0))) if body else {}
        if attrs.get("loaded") != "1":
            problems.append("the page did not finish loading in chromium (exit %d): %s" % (run.returncode, run.stderr.strip()[-300:]))
        else:
            if int(attrs["images"]) != expected:
                problems.append("chromium shows %s images, the file has %d" % (attrs["images"], expected))
            if attrs["broken"]:
                problems.append("images not loaded: " + attrs["broken"])
        pdf = os.path.join(tmp, "print.pdf")
        if print_pdf:
            subprocess.run(chromium_command(chromium, tmp + "/profile") + ["--no-pdf-header-footer", "--print-to-pdf=" + pdf,
                                                                           "file://" + os.path.abspath(path)],
                           capture_output=True, timeout=120)
        if print_pdf and (not os.path.exists(pdf) or open(pdf, "rb").read(5) != b"%PDF-"):
            problems.append("chromium did not print it to PDF")
        if screenshot_dir:
            png = os.path.join(screenshot_dir, os.path.basename(os.path.dirname(os.path.abspath(path))) + ".png")
            subprocess.run(chromium_command(chromium, tmp + "/profile") + ["--window-size=1200,2600", "--hide-scrollbars",
                           "--screenshot=" + png, "file://" + os.path.abspath(path)], capture_output=True, timeout=120)
    if not quiet:
        verdict = "; ".join(problems) if problems else "renders, every figure loaded, prints"
        print("%s: %s (%d figures)" % (path, verdict, expected))
    return problems, expected


def check_catches_broken_pages(chromium):
    """The check itself: a page with a corrupt figure and one from the network must fail it."""
    with tempfile.TemporaryDirectory(prefix="orbcal-browser-control-") as tmp:
        page = os.path.join(tmp, "report.html")
        with open(page, "w", encoding="utf-8") as f:
            f.write('<!DOCTYPE html><html><head><title>control</title></head><body><p>control page</p>'
                    '<img alt="corrupt" src="data:image/png;base64,iVBORw0KGgoAAAA="><img alt="remote" '
                    'src="http://example.invalid/figure.png"></body></html>')
        problems, _ = check(chromium, page, None, print_pdf=False, quiet=True)
    text = " ".join(problems)
    if not all(w in text for w in ("corrupt", "remote", "http://example.invalid")):
        sys.exit("check_report.py: the check passes a page with a corrupt and a remote figure: " + text)
    print("control page: a corrupt and a remote figure are flagged")


FIG8_STUDY = """format: orbcal-study-1
name: fig8-small
job: experiment
preset: fig8
options: {repetitions: 1, quiet: true, source: synthetic, ident: 30, valid: 20}
seeds: [1, 2]
"""


def orbcal_step(orbcal, args):
    run = subprocess.run([orbcal] + args, capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        sys.exit("check_report.py: orbcal %s failed (exit %d): %s" % (args[0], run.returncode, run.stderr.strip()[-500:]))


def make_reports(orbcal, work):
    """Every kind of report, small: calibrate, diagnose and evaluate on measured data with a hidden
    compliance; orbcal run (rendered images) and calibrate on its 20 identification images (the fewest of which the
    default hold-out keeps the 10 out that the held-out test needs); a study's merge."""
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    data = os.path.join(work, "data")
    orbcal_step(orbcal, ["simulate", "-o", data, "-n", "120", "--sessions", "2", "--payload-kg", "0", "1.25", "--inject",
                         "compliance:2", "--seed", "3"])
    orbcal_step(orbcal, ["calibrate", data + "/measurements.yaml", "-o", work + "/calibrate", "--effects", "compliance:2", "--quiet"])
    orbcal_step(orbcal, ["diagnose", data + "/measurements.yaml", "-o", work + "/diagnose", "--quiet"])
    orbcal_step(orbcal, ["evaluate", "--model", work + "/calibrate/model.yaml", "--data", data + "/measurements.yaml", "-o",
                         work + "/evaluate"])
    orbcal_step(orbcal, ["run", "--ident", "20", "--valid", "8", "--methods", "LM", "-o", work + "/run", "--quiet"])
    images = [d for d in sorted(os.listdir(work + "/run/datasets")) if "-ident-" in d]
    orbcal_step(orbcal, ["calibrate", work + "/run/datasets/" + images[0], "-o", work + "/calibrate-images", "--quiet"])
    with open(work + "/fig8.yaml", "w") as f:
        f.write(FIG8_STUDY)
    orbcal_step(orbcal, ["study", "run", work + "/fig8.yaml", "-o", work + "/study", "-j", "2"])
    return [os.path.join(work, name, "report.html")
            for name in ("calibrate", "diagnose", "evaluate", "run/main", "calibrate-images", "study/merged")]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbcal")
    parser.add_argument("--work")
    parser.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium")
    parser.add_argument("--screenshots", metavar="DIR", help="also save a screenshot of each page into DIR (its folder's name)")
    parser.add_argument("reports", nargs="*")
    args = parser.parse_args()
    if not os.access(args.chromium, os.X_OK):
        print("orbcal-test-skipped: chromium not found at %s (tools/install-deps.sh --tests installs it)" % args.chromium)
        return 0
    check_catches_broken_pages(args.chromium)
    reports = args.reports
    if args.screenshots:
        os.makedirs(args.screenshots, exist_ok=True)
    if args.orbcal:
        if not args.work:
            parser.error("--orbcal needs --work")
        reports = reports + make_reports(args.orbcal, args.work)
    if not reports:
        parser.error("no report given")
    failed, figures = 0, 0
    for path in reports:
        problems, n = check(args.chromium, path, args.screenshots)
        failed += bool(problems)
        figures += n
    if args.orbcal and figures == 0:  # the reports made here have figures: none drawn means matplotlib is absent
        print("orbcal-test-skipped: no figure drawn (python3 with matplotlib is needed); pages checked without figures")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
