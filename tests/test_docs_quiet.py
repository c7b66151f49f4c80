"""``make docs`` says only what needs saying: no library's INFO messages (a module the
theme imports sets the root logger up at INFO when nothing has), and the notebook's kernel
logs errors only (it warned on every build that it talks to the build over local TCP)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_docs_configuration_keeps_the_build_quiet():
    probe = (
        "import json, logging, os, runpy\n"
        "runpy.run_path('docs/conf.py')\n"
        # what a module the theme imports does (a11y_pygments), without the theme installed
        "logging.basicConfig(format='# %(message)s', level=logging.INFO)\n"
        "root = logging.getLogger()\n"
        "spec = os.path.join(os.environ['JUPYTER_PATH'].split(os.pathsep)[0], 'kernels',"
        " 'python3', 'kernel.json')\n"
        "print(json.dumps({'level': root.getEffectiveLevel(),"
        " 'info': logging.getLogger('numexpr.utils').isEnabledFor(logging.INFO),"
        " 'argv': json.load(open(spec))['argv']}))\n")
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True,
                         text=True, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["level"] == 30 and not got["info"]  # WARNING: no library's INFO printed
    assert "--IPKernelApp.log_level=ERROR" in got["argv"]
    assert got["argv"][0] == sys.executable  # the kernel runs this interpreter
    assert out.stderr == ""
