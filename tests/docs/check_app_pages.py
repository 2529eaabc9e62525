#!/usr/bin/python3
"""Every long flag that an app's --help lists appears on the app's documentation page.

Runs BIN_DIR/<app> --help for each app, takes every long flag that the help's option lists declare
(a line that starts with the option: `  --csv TEXT`, `  -o,--output TEXT`; flags that the prose
only mentions, such as another app's, are not the app's) and looks for it in docs/apps/<app>.md
as a whole flag (`--fps` is not found inside `--fps-x`). Fails naming the app, the flag and the
page.

    /usr/bin/python3 tests/docs/check_app_pages.py BIN_DIR [DOCS_APPS_DIR]
"""
import pathlib
import re
import subprocess
import sys

APPS = ["dba-covariance", "dba-evaluate", "dba-posegraph", "droid2rawlog", "simul-dba"]
FLAG = re.compile(r"(?<![\w-])--[a-z0-9][a-z0-9-]*(?![\w-])")
DECLARED = re.compile(r"^\s+(?:-\w,)?(--[a-z0-9][a-z0-9-]*)(?![\w-])", re.M)


def flags_in(text):
    return set(FLAG.findall(text))


def declared_in(help_text):
    return set(DECLARED.findall(help_text))


def main(argv):
    if len(argv) not in (2, 3):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    bin_dir = pathlib.Path(argv[1])
    pages = pathlib.Path(argv[2]) if len(argv) == 3 else \
        pathlib.Path(__file__).resolve().parents[2] / "docs" / "apps"
    missing = []
    for app in APPS:
        exe = bin_dir / app
        page = pages / f"{app}.md"
        if not exe.exists():
            missing.append(f"{app}: {exe} not found (build the apps first)")
            continue
        if not page.exists():
            missing.append(f"{app}: no page {page}")
            continue
        run = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=60)
        if run.returncode != 0:
            missing.append(f"{app}: --help exited with {run.returncode}: {run.stderr.strip()}")
            continue
        documented = flags_in(page.read_text(encoding="utf-8"))
        helped = declared_in(run.stdout)
        if not helped:
            missing.append(f"{app}: --help printed no long flag (is it the app's help?)")
        for flag in sorted(helped - documented):
            missing.append(f"{app}: {flag} is in --help but not on {page}")
        print(f"check_app_pages: {app}: {len(helped)} flags in --help, "
              f"{len(helped & documented)} on {page.name}")
    for m in missing:
        print(f"check_app_pages: {m}", file=sys.stderr)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
