#!/usr/bin/python3
"""The Python SDK installed and used as docs/sdk.md section 1 says, with no URS_OMNIIDL_BACKEND_DIR:

  - the documented pip install into a venv (--system-site-packages, --no-build-isolation
    --no-index ./python) of a copy of the checkout: Interface.from_idl works with the omniidl
    back-end the package carries, and the copy holds the same files after as before (no build/,
    no urslink.egg-info/);
  - the install tree (<prefix>/share/urslink/python, as `cmake --install` and the .deb lay it out):
    the back-end of <prefix>/share/urslink/idl;
  - a checkout (PYTHONPATH=<checkout>/python): the checkout's idl/omniidl_planet;
  - URS_OMNIIDL_BACKEND_DIR still overrides.

Offline: pip uses Debian's setuptools and python3-protobuf (needs python3-venv).
  python3 -m unittest -v tests/python/test_sdk_install.py   (from the repository root)"""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
PY = "/usr/bin/python3"
# Which back-end folder the SDK found, and the interface it loaded with it.
PROBE = """import json, sys, urslink
from urslink import interface
print(json.dumps({"backend": interface._backend_dir(), "name": urslink.Interface.from_idl(sys.argv[1]).name}))"""
# What the copy of the checkout holds: what the documented install reads, nothing built.
COPIED = ("python", os.path.join("idl", "omniidl_planet"))
NOT_COPIED = shutil.ignore_patterns("__pycache__", "*.pyc", "build", "*.egg-info")


def files_below(folder):
    """Every file and folder below `folder`, relative to it."""
    found = set()
    for parent, folders, files in os.walk(folder):
        for name in folders + files:
            found.add(os.path.relpath(os.path.join(parent, name), folder))
    return found


def run(argv, cwd, env=None):
    done = subprocess.run(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=240)
    if done.returncode != 0:
        raise AssertionError("%s exited with status %d:\n%s" % (" ".join(argv), done.returncode, done.stdout))
    return done.stdout


class Workspace(unittest.TestCase):
    """A temporary folder with a copy of the checkout's parts the SDK needs and an IDL file outside
    them; `probe(python, **env)` loads the IDL file there without URS_OMNIIDL_BACKEND_DIR or PYTHONPATH."""
    maxDiff = None

    @classmethod
    def setUpClass(cls):
        cls.work = tempfile.mkdtemp(prefix="urslink-install-")
        cls.checkout = os.path.join(cls.work, "checkout")
        for part in COPIED:
            shutil.copytree(os.path.join(ROOT, part), os.path.join(cls.checkout, part), ignore=NOT_COPIED)
        cls.idl = os.path.join(cls.work, "Thermostat.idl")   # outside every tree the SDK looks in
        shutil.copy(os.path.join(ROOT, "examples", "python", "Thermostat.idl"), cls.idl)
        cls.env = {k: v for k, v in os.environ.items() if k not in ("URS_OMNIIDL_BACKEND_DIR", "PYTHONPATH")}

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.work, ignore_errors=True)

    def probe(self, python, **env):
        out = run([python, "-c", PROBE, self.idl], cwd=self.work, env=dict(self.env, **env))
        return json.loads(out.strip().splitlines()[-1])


class PipInstallTest(Workspace):
    """docs/sdk.md's steps: a venv seeing Debian's packages, then pip install ./python from the checkout."""

    @classmethod
    def setUpClass(cls):
        super().setUpClass()
        cls.venv = os.path.join(cls.work, "venv")
        run([PY, "-m", "venv", "--system-site-packages", cls.venv], cwd=cls.work)
        cls.before = files_below(cls.checkout)
        run([os.path.join(cls.venv, "bin", "pip"), "install", "--no-build-isolation", "--no-index", "--no-cache-dir",
             "--disable-pip-version-check", "./python"], cwd=cls.checkout, env=cls.env)
        cls.after = files_below(cls.checkout)

    def test_the_checkout_is_left_as_it_was(self):
        self.assertEqual(sorted(self.after - self.before), [], "the install left these in the checkout")
        self.assertEqual(sorted(self.before - self.after), [], "the install removed these from the checkout")

    def test_idl_loads_with_the_backend_the_package_carries(self):
        python = os.path.join(self.venv, "bin", "python")
        site = run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], cwd=self.work).strip()
        self.assertEqual(self.probe(python),
                         {"backend": os.path.join(site, "urslink", "omniidl_planet"), "name": "Demo.Thermostat"})


class LayoutTest(Workspace):
    """The package where the .deb and `cmake --install` put it, and in a checkout."""

    def test_install_tree(self):
        data = os.path.join(self.work, "prefix", "share", "urslink")
        shutil.copytree(os.path.join(self.checkout, "python", "urslink"), os.path.join(data, "python", "urslink"),
                        ignore=NOT_COPIED)
        backend = os.path.join(data, "idl", "omniidl_planet")
        shutil.copytree(os.path.join(self.checkout, "idl", "omniidl_planet"), backend, ignore=NOT_COPIED)
        self.assertEqual(self.probe(PY, PYTHONPATH=os.path.join(data, "python")),
                         {"backend": backend, "name": "Demo.Thermostat"})

    def test_checkout_and_override(self):
        backend = os.path.join(self.checkout, "idl", "omniidl_planet")
        python = os.path.join(self.checkout, "python")
        self.assertEqual(self.probe(PY, PYTHONPATH=python), {"backend": backend, "name": "Demo.Thermostat"})
        override = os.path.join(self.work, "elsewhere")
        shutil.copytree(backend, override, ignore=NOT_COPIED)
        self.assertEqual(self.probe(PY, PYTHONPATH=python, URS_OMNIIDL_BACKEND_DIR=override),
                         {"backend": override, "name": "Demo.Thermostat"})


if __name__ == "__main__":
    unittest.main()
