"""Types and service interfaces described at run time: the message classes of an IDL file (Types)
or of one IDL interface (Interface), built from a descriptor set (from camus.registry Describe, a
.desc file, or an IDL file through the project's omniidl back-end and protoc)."""
import os
import shutil
import subprocess
import tempfile

from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory
from google.protobuf.message import DecodeError

from ._proto import urs_options_pb2 as uo
from .errors import UserException

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
# Where the omniidl Planet back-end is looked for, after URS_OMNIIDL_BACKEND_DIR (an override):
_DEFAULT_BACKEND_DIRS = (
    # the copy python/setup.py puts into the package when pip builds it
    os.path.join(_PACKAGE_DIR, "omniidl_planet"),
    # the package's own tree: <prefix>/share/urslink/python/urslink -> <prefix>/share/urslink/idl
    # (the .deb, `cmake --install`), and a checkout's python/urslink -> idl
    os.path.join(os.path.dirname(os.path.dirname(_PACKAGE_DIR)), "idl", "omniidl_planet"),
    "/usr/share/urslink/idl/omniidl_planet",
    "/usr/local/share/urslink/idl/omniidl_planet",
    "/opt/urslink/share/urslink/idl/omniidl_planet",
)


class IdlError(Exception):
    """An IDL file could not be turned into an interface description; the text says why."""


class Method:
    """One operation: `name`, `request` and `reply` message classes, `oneway`, `raises` (full
    names of the exceptions it declares)."""

    def __init__(self, name, request, reply, oneway, raises):
        self.name = name
        self.request = request
        self.reply = reply
        self.oneway = oneway
        self.raises = raises

    def __repr__(self):
        return "Method(%s(%s) -> %s%s)" % (self.name, self.request.DESCRIPTOR.full_name,
                                           self.reply.DESCRIPTOR.full_name, ", oneway" if self.oneway else "")


# Files compile_idl() adds to every descriptor set: their messages are no type of the IDL file.
_SUPPORT_FILES = frozenset((descriptor_pb2.DESCRIPTOR.name, uo.DESCRIPTOR.name))


def _message_names(prefix, messages):
    for m in messages:
        yield prefix + m.name
        yield from _message_names(prefix + m.name + ".", m.nested_type)


class Types:
    """The message types of a descriptor set, whether or not it declares a service: e.g. the
    structs of an IDL file with no interface (OpenRTM-aist's BasicDataType.idl: "RTC.TimedLong"),
    to publish and read events of. `descriptor_set` (the serialized FileDescriptorSet), `pool`,
    `messages` (the full names of the messages it declares, sorted; those of descriptor.proto and
    urs_options.proto left out)."""

    def __init__(self, descriptor_set):
        self._files = descriptor_pb2.FileDescriptorSet.FromString(descriptor_set).file
        self.descriptor_set = bytes(descriptor_set)
        self.pool = descriptor_pool.DescriptorPool()
        for f in self._files:
            self.pool.Add(f)
        self.messages = sorted(name for f in self._files if f.name not in _SUPPORT_FILES
                               for name in _message_names(f.package + "." if f.package else "", f.message_type))
        self._factory = message_factory.MessageFactory(self.pool)

    def message_class(self, full_name):
        """The class of message `full_name` (e.g. "Demo.Reading"); KeyError if the description has none."""
        descriptor = self.pool.FindMessageTypeByName(full_name)
        make = getattr(message_factory, "GetMessageClass", None)
        return make(descriptor) if make else self._factory.GetPrototype(descriptor)

    def decode(self, event):
        """The payload of `event` (a planet_pb2.Event) as a message of its content type. ValueError
        when the content type is none of these types or the payload does not parse as one."""
        try:
            cls = self.message_class(event.content_type)
        except KeyError:
            raise ValueError("the event on '%s' has content type '%s', which is none of these types: load the "
                             "IDL file that declares it" % (event.topic, event.content_type)) from None
        try:
            return cls.FromString(event.payload)
        except DecodeError as e:
            raise ValueError("the payload of the event on '%s' (%d bytes) is no %s: %s"
                             % (event.topic, len(event.payload), event.content_type, e)) from None

    def to_json(self, message):
        return json_format.MessageToJson(message, preserving_proto_field_name=True,
                                         including_default_value_fields=True)

    def __repr__(self):
        return "Types(%s)" % ", ".join(self.messages)

    # ---- where descriptions come from ------------------------------------------------------------

    @classmethod
    def from_descriptor_set_file(cls, path, **options):
        """From a serialized FileDescriptorSet on disk (e.g. the build's URS_DESCRIPTOR_SET .desc).
        `options` are the class's own (Interface: `name`)."""
        with open(path, "rb") as f:
            return cls(f.read(), **options)

    @classmethod
    def from_idl(cls, path, include_dirs=(), **options):
        """From an IDL file, translated at run time by the project's omniidl back-end
        (docs/idl-mapping.md) and compiled by protoc into a descriptor set (compile_idl()).
        `options` are the class's own (Interface: `name`).

        Needs the omniidl and protoc programs (Debian: omniidl, protobuf-compiler); found on PATH
        or through URS_OMNIIDL / URS_PROTOC. The back-end folder is URS_OMNIIDL_BACKEND_DIR, else
        the copy inside the package (pip), else the package's tree (share/urslink/idl/omniidl_planet
        installed, idl/omniidl_planet in a checkout)."""
        return cls(compile_idl(path, include_dirs), **options)


class Interface(Types):
    """An IDL interface as Planet sees it: `name` ("Demo.Thermostat"), `descriptor_set` (the
    serialized FileDescriptorSet, imports included: what an agent registers), `methods` (name ->
    Method), and the message classes of every type the description holds (as Types)."""

    def __init__(self, descriptor_set, name=None):
        super().__init__(descriptor_set)
        services = []
        method_options = {}
        for f in self._files:
            package = f.package + "." if f.package else ""
            for s in f.service:
                services.append(package + s.name)
                for m in s.method:
                    method_options[(package + s.name, m.name)] = m.options
        if name is None:
            if not services:
                raise ValueError("the descriptor set declares no service (its IDL file has no interface): "
                                 "load its message types with urslink.Types")
            if len(services) > 1:
                raise ValueError("the descriptor set declares %d services (%s): name the interface"
                                 % (len(services), ", ".join(services)))
            name = services[0]
        try:
            self.service = self.pool.FindServiceByName(name)
        except KeyError:
            raise ValueError("the descriptor set has no service '%s' (it has: %s)"
                             % (name, ", ".join(services) or "none")) from None
        self.name = name
        self.methods = {}
        for m in self.service.methods:
            options = method_options.get((name, m.name), descriptor_pb2.MethodOptions())
            self.methods[m.name] = Method(m.name, self.message_class(m.input_type.full_name),
                                          self.message_class(m.output_type.full_name),
                                          bool(options.Extensions[uo.oneway]), list(options.Extensions[uo.raises]))

    def _exception_type(self, name):
        if "." not in name:
            package = self.name.rsplit(".", 1)[0] if "." in self.name else ""
            name = package + "." + name if package else name
        return name

    def exception(self, name, _message="", **fields):
        """A UserException of the IDL exception `name` ("OutOfRange" in the interface's module, or
        a full name) with these fields, to raise from an agent. `_message` is the Reply's text
        (default: the type and its fields), as a C++ agent's Outcome::raise(exception, message)."""
        full = self._exception_type(name)
        value = self.message_class(full)(**fields)
        return UserException(full, value.SerializeToString(), _message, value)

    def decode_exception(self, type_name, payload, message=""):
        """A UserException for a Reply with USER_EXCEPTION, its value decoded when the type is known."""
        try:
            value = self.message_class(type_name).FromString(payload)
        except Exception:  # unknown type or a payload that does not parse: keep the raw bytes
            value = None
        return UserException(type_name, payload, message, value)

    def __repr__(self):
        return "Interface(%s: %s)" % (self.name, ", ".join(self.methods))


def _tool(env, program, package):
    found = os.environ.get(env) or shutil.which(program)
    if not found:
        raise IdlError("%s not found: install the Debian package %s, or set %s to its path" % (program, package, env))
    return found


def _backend_dir():
    configured = os.environ.get("URS_OMNIIDL_BACKEND_DIR")
    if configured:
        return configured
    for candidate in _DEFAULT_BACKEND_DIRS:
        if os.path.isfile(os.path.join(candidate, "planet_proto.py")):
            return candidate
    raise IdlError("the omniidl Planet back-end (planet_proto.py) is in none of %s: set URS_OMNIIDL_BACKEND_DIR "
                   "to the folder idl/omniidl_planet of URSLink" % ", ".join(_DEFAULT_BACKEND_DIRS))


def compile_idl(path, include_dirs=()):
    """The serialized FileDescriptorSet (imports included, dependencies first) of IDL file `path`."""
    if not os.path.isfile(path):
        raise IdlError("IDL file '%s' does not exist" % path)
    omniidl = _tool("URS_OMNIIDL", "omniidl", "omniidl")
    protoc = _tool("URS_PROTOC", "protoc", "protobuf-compiler")
    backend = _backend_dir()
    base = os.path.splitext(os.path.basename(path))[0]
    with tempfile.TemporaryDirectory(prefix="urslink-idl-") as work:
        argv = [omniidl, "-p", backend, "-b", "planet_proto", "-Wball", "-C", work]
        for directory in [os.path.dirname(os.path.abspath(path))] + list(include_dirs):
            argv.append("-I" + directory)
        argv.append(path)
        run = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        if run.returncode != 0:
            raise IdlError("omniidl could not translate '%s' (exit status %d; back-end folder %s):\n%s"
                           % (path, run.returncode, backend, run.stdout.strip()))
        proto = os.path.join(work, base + ".proto")
        if not os.path.isfile(proto):
            raise IdlError("omniidl succeeded on '%s' but wrote no %s.proto (is %s the planet_proto back-end?)"
                           % (path, base, backend))
        # urs_options.proto and descriptor.proto come from the descriptors compiled into this
        # package, as urs::schema::load_idl() does in C++: nothing else needs installing.
        known = descriptor_pb2.FileDescriptorSet()
        descriptor_pb2.DESCRIPTOR.CopyToProto(known.file.add())
        uo.DESCRIPTOR.CopyToProto(known.file.add())
        imports = os.path.join(work, "imports.pb")
        with open(imports, "wb") as f:
            f.write(known.SerializeToString())
        out = os.path.join(work, base + ".desc")
        run = subprocess.run([protoc, "--descriptor_set_in=" + imports, "--include_imports",
                              "--descriptor_set_out=" + out, "-I" + work, base + ".proto"],
                             cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        if run.returncode != 0:
            raise IdlError("protoc could not compile the Planet schema of '%s':\n%s" % (path, run.stdout.strip()))
        with open(out, "rb") as f:
            return f.read()
