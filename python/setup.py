"""What pyproject.toml cannot say to setuptools (the metadata is there; docs/sdk.md, "Install"):

- The omniidl Planet back-end (idl/omniidl_planet/*.py, next to this folder in a checkout) is
  copied into the built package as urslink/omniidl_planet, so that loading IDL at run time
  (from_idl) works after `pip install` with nothing else installed and no environment variable.
  An sdist carries the copy in its own urslink/omniidl_planet, from which its wheel takes it.
- setuptools' scratch folders (build/, urslink.egg-info/) go to a temporary folder removed when
  the build ends, not into the checkout: pip builds in the source folder itself, and setuptools
  has no option to write elsewhere other than these two paths."""
import atexit
import os
import shutil
import tempfile

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

HERE = os.path.dirname(os.path.abspath(__file__))
BACKEND_IN_PACKAGE = os.path.join("urslink", "omniidl_planet")
BACKEND_SOURCES = (os.path.join(os.path.dirname(HERE), "idl", "omniidl_planet"),   # a checkout
                   os.path.join(HERE, BACKEND_IN_PACKAGE))                          # an unpacked sdist


def backend_files():
    """The back-end's modules, from the first source that has them; a build without them fails."""
    for folder in BACKEND_SOURCES:
        if os.path.isfile(os.path.join(folder, "planet_proto.py")):
            return [os.path.join(folder, name) for name in sorted(os.listdir(folder)) if name.endswith(".py")]
    raise SystemExit("urslink: the omniidl Planet back-end (planet_proto.py) is in none of %s: build the "
                     "package from a URSLink checkout (its python/ folder) or from its sdist"
                     % ", ".join(BACKEND_SOURCES))


def copy_backend(command, package_root):
    target = os.path.join(package_root, BACKEND_IN_PACKAGE)
    command.mkpath(target)
    for path in backend_files():
        command.copy_file(path, target)


class BuildPyWithBackend(build_py):
    def run(self):
        super().run()
        copy_backend(self, self.build_lib)


class SdistWithBackend(sdist):
    def make_release_tree(self, base_dir, files):
        super().make_release_tree(base_dir, files)
        copy_backend(self, base_dir)


scratch = tempfile.mkdtemp(prefix="urslink-build-")
atexit.register(shutil.rmtree, scratch, True)

setup(cmdclass={"build_py": BuildPyWithBackend, "sdist": SdistWithBackend},
      options={"build": {"build_base": os.path.join(scratch, "build")}, "egg_info": {"egg_base": scratch}})
