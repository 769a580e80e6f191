# CORBA IDL (omniidl AST) -> Planet schema (proto3 text). The rules are in docs/idl-mapping.md;
# keep the two in step. Translation collects every error instead of stopping at the first one.
"""Translates an omniidl AST into proto3 files carrying urs.options custom options."""

import os
import re

from omniidl import idlast, idltype

OPTIONS_PROTO = "urs_options.proto"

# IDL base type kind -> (Protobuf scalar, IDL spelling).
BASE_TYPES = {
    idltype.tk_short: ("int32", "short"),
    idltype.tk_long: ("int32", "long"),
    idltype.tk_ushort: ("uint32", "unsigned short"),
    idltype.tk_ulong: ("uint32", "unsigned long"),
    idltype.tk_longlong: ("int64", "long long"),
    idltype.tk_ulonglong: ("uint64", "unsigned long long"),
    idltype.tk_float: ("float", "float"),
    idltype.tk_double: ("double", "double"),
    idltype.tk_boolean: ("bool", "boolean"),
    idltype.tk_char: ("string", "char"),
    idltype.tk_wchar: ("string", "wchar"),
    idltype.tk_octet: ("uint32", "octet"),
}

# Refused base types -> (construct, reason).
REFUSED_BASE = {
    idltype.tk_any: ("'any'", "an any carries its TypeCode at run time but a Planet schema is "
                     "static; use a union, a struct or sequence<octet>"),
    idltype.tk_TypeCode: ("'TypeCode'", "type descriptions are not values in a Planet schema"),
    idltype.tk_Principal: ("'Principal'", "it is a deprecated CORBA type with no equivalent"),
    idltype.tk_longdouble: ("'long double'", "Protobuf has no extended-precision floating "
                            "point; use double"),
}

REASON_OBJREF = ("object references cannot cross Planet (no remote object identity); "
                 "pass a name or an ID instead")
REASON_VALUE = ("valuetypes (objects by value, with sharing and inheritance) have no Planet "
                "equivalent; use a struct")
REASON_NATIVE = "native types are language-specific and cannot be transported"
REASON_FIXED = ("Protobuf has no decimal fixed-point type; use a string or a scaled "
                "long long")
REASON_LOCAL = "local interfaces cannot be invoked remotely"
REASON_ABSTRACT = ("abstract interfaces may stand for valuetypes, which have no Planet "
                   "equivalent; use a concrete interface")
REASON_CONTEXT = "context clauses pass CORBA Context objects, which have no Planet equivalent"

MODE_NAMES = {0: "PARAM_MODE_IN", 1: "PARAM_MODE_OUT", 2: "PARAM_MODE_INOUT"}


def quote(text):
    """A proto string literal."""
    out = []
    for ch in text:
        if ch in "\\\"":
            out.append("\\" + ch)
        elif " " <= ch <= "~":
            out.append(ch)
        else:
            out.extend("\\%03o" % b for b in ch.encode("utf-8"))
    return '"' + "".join(out) + '"'


def upper_snake(name):
    """NavigationState -> NAVIGATION_STATE, HTTPStatus -> HTTP_STATUS, Nav_State -> NAV_STATE."""
    text = re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", name)
    text = re.sub(r"([A-Z]+)([A-Z][a-z])", r"\1_\2", text)
    return re.sub(r"_+", "_", text).upper()


def json_name(name):
    """Protobuf's default JSON name: underscores removed, the following letter capitalised."""
    out, upper = [], False
    for ch in name:
        if ch == "_":
            upper = True
        else:
            out.append(ch.upper() if upper else ch)
            upper = False
    return "".join(out)


def proto_file_name(idl_path):
    return os.path.splitext(os.path.basename(idl_path))[0] + ".proto"


def location(decl):
    return "%s:%d" % (decl.file(), decl.line())


def colons(scoped_name):
    return "::".join(scoped_name)


def resolve(idl_type, dims):
    """Strips typedefs, collecting array dimensions (outermost first)."""
    dims = list(dims)
    while idl_type.kind() == idltype.tk_alias:
        declarator = idl_type.decl()
        dims.extend(declarator.sizes())
        idl_type = declarator.alias().aliasType()
    return idl_type, dims


def full_decl(decl):
    """The full declaration behind a forward declaration (None if never defined)."""
    if isinstance(decl, (idlast.Forward, idlast.StructForward, idlast.UnionForward)):
        return decl.fullDecl()
    return decl


class Mapped(object):
    """How an IDL type is carried in one field.

    proto: Protobuf type (scalar keyword or fully qualified ".pkg.Msg"); idl: IDL spelling of the
    element type; token: a name-safe spelling used to name wrappers; dims: array dimensions;
    bound: bound of the string/sequence named by idl (0 = unbounded).
    """

    def __init__(self, proto, idl, token, repeated=False, dims=(), bound=0):
        self.proto = proto
        self.idl = idl
        self.token = token
        self.repeated = repeated
        self.dims = list(dims)
        self.bound = bound

    def idl_with_dims(self):
        return self.idl + "".join("[%d]" % d for d in self.dims)


class Field(object):
    def __init__(self, name, number, mapped, options):
        self.name = name
        self.number = number
        self.mapped = mapped
        self.options = options  # list of (option name, literal) after the type options

    def render(self, indent, in_oneof=False):
        opts = [("idl_type", quote(self.mapped.idl))]
        opts += [("array_dims", str(d)) for d in self.mapped.dims]
        if self.mapped.bound:
            opts.append(("bound", str(self.mapped.bound)))
        opts += self.options
        label = "repeated " if self.mapped.repeated and not in_oneof else ""
        text = ", ".join("(urs.options.%s) = %s" % opt for opt in opts)
        return ["%s%s%s %s = %d [%s];" % (indent, label, self.mapped.proto, self.name,
                                          self.number, text)]


class Message(object):
    """A top-level message; wrappers for nested sequences/arrays are nested inside it."""

    def __init__(self, translator, full_name, kind, decl, repo_id=None):
        self.translator = translator
        self.full_name = full_name
        self.name = full_name.split(".")[-1]
        self.kind = kind
        self.decl = decl
        self.repo_id = repo_id
        self.fields = []
        self.oneof = None  # (name, [Field]) for unions
        self.wrappers = []
        self.wrapper_names = set()
        self.json_names = {}

    def add_field(self, field, where_decl, in_oneof=False):
        key = json_name(field.name).lower()
        if key in self.json_names:
            self.translator.error(where_decl, "field '%s' of message '%s' has the same JSON name "
                                  "as field '%s' (JSON names ignore '_' and case); rename one"
                                  % (field.name, self.full_name, self.json_names[key]))
        self.json_names[key] = field.name
        if in_oneof:
            self.oneof[1].append(field)
        else:
            self.fields.append(field)

    def wrapper(self, item):
        """A nested message holding one value of a repeated mapping; returns its full name."""
        name = item.token
        if name not in self.wrapper_names:
            self.wrapper_names.add(name)
            nested = Message(self.translator, self.full_name + "." + name, "MESSAGE_KIND_WRAPPER",
                             self.decl)
            nested.fields.append(Field("items", 1, item, []))
            self.wrappers.append(nested)
        return "." + self.full_name + "." + name

    def render(self, indent=""):
        inner = indent + "  "
        lines = ["%smessage %s {" % (indent, self.name),
                 "%soption (urs.options.message_kind) = %s;" % (inner, self.kind)]
        if self.repo_id:
            lines.append("%soption (urs.options.message_repository_id) = %s;"
                         % (inner, quote(self.repo_id)))
        for wrapper in self.wrappers:
            lines += wrapper.render(inner)
        for field in self.fields:
            lines += field.render(inner)
        if self.oneof is not None:
            lines.append("%soneof %s {" % (inner, self.oneof[0]))
            for field in self.oneof[1]:
                lines += field.render(inner + "  ", in_oneof=True)
            lines.append(inner + "}")
        lines.append(indent + "}")
        return lines


class Enum(object):
    def __init__(self, full_name, repo_id):
        self.name = full_name.split(".")[-1]
        self.repo_id = repo_id
        self.values = []  # (proto name, number, IDL enumerator)

    def render(self):
        lines = ["enum %s {" % self.name,
                 "  option (urs.options.enum_repository_id) = %s;" % quote(self.repo_id)]
        for name, number, idl_name in self.values:
            lines.append("  %s = %d [(urs.options.idl_enumerator) = %s];"
                         % (name, number, quote(idl_name)))
        lines.append("}")
        return lines


class Service(object):
    def __init__(self, name, repo_id, bases):
        self.name = name
        self.repo_id = repo_id
        self.bases = bases
        self.methods = []  # (name, request, reply, [(option, literal)])

    def render(self):
        lines = ["service %s {" % self.name,
                 "  option (urs.options.service_repository_id) = %s;" % quote(self.repo_id)]
        lines += ["  option (urs.options.service_bases) = %s;" % quote(b) for b in self.bases]
        for name, request, reply, options in self.methods:
            lines.append("  rpc %s(%s) returns (%s) {" % (name, request, reply))
            lines += ["    option (urs.options.%s) = %s;" % opt for opt in options]
            lines.append("  }")
        lines.append("}")
        return lines


class ProtoFile(object):
    def __init__(self, idl_path):
        self.idl_path = idl_path
        self.name = proto_file_name(idl_path)
        self.package = None
        self.package_where = None
        self.package_error = False
        self.imports = set()         # files whose types are used
        self.option_imports = set()  # files only named by (urs.options.raises)
        self.items = []  # objects with render() -> [lines], or comment strings

    def render(self):
        idl_name = os.path.basename(self.idl_path)
        lines = ["// Generated from %s by the Planet back-end of omniidl (idl/omniidl_planet)."
                 % idl_name,
                 "// Do not edit: change the IDL. Mapping rules: docs/idl-mapping.md.",
                 'syntax = "proto3";', ""]
        if self.package:
            lines += ["package %s;" % self.package, ""]
        for name in sorted(self.imports | {OPTIONS_PROTO}):
            lines.append("import %s;" % quote(name))
        for name in sorted(self.option_imports - self.imports):
            lines.append("import public %s;  // declares exceptions named by raises" % quote(name))
        lines += ["", "option (urs.options.idl_file) = %s;" % quote(idl_name)]
        for item in self.items:
            lines.append("")
            lines += [item] if isinstance(item, str) else item.render()
        return "\n".join(lines) + "\n"


class Callable(object):
    """One Planet method: an operation, or one accessor of an attribute."""

    def __init__(self, name, decl, owner, params, result, oneway, raises, repo_id, attribute):
        self.name = name
        self.decl = decl          # the Operation or Attribute (for locations)
        self.owner = owner        # declaring Interface
        self.params = params      # [(identifier, type, direction 0/1/2, decl)]
        self.result = result      # IDL type, or None for void
        self.oneway = oneway
        self.raises = raises      # [Exception decl]
        self.repo_id = repo_id
        self.attribute = attribute


class Translator(object):
    def __init__(self, include_all):
        self.include_all = include_all
        self.files = {}     # IDL path -> ProtoFile, in first-seen order
        self.order = []
        self.symbols = {}   # full Protobuf name -> description of what generated it
        self.errors = []
        self.done = set()   # ids of declarations already translated

    # --- entry points -----------------------------------------------------------------------

    def translate(self, tree):
        self.file_for(tree.file())  # the main file always yields a .proto, even if empty
        for decl in tree.declarations():
            self.declaration(decl)

    def finish(self):
        seen, out = set(), []
        for error in self.errors:
            if error not in seen:
                seen.add(error)
                out.append(error)
        return out

    def outputs(self):
        return [(self.files[path].name, self.files[path].render()) for path in self.order]

    # --- helpers ----------------------------------------------------------------------------

    def error(self, decl, text):
        self.errors.append("%s: error: %s" % (location(decl), text))

    def refuse(self, decl, what, construct, reason):
        self.error(decl, "%s%s is not supported by the Planet mapping: %s"
                   % (what + ": " if what else "", construct, reason))

    def file_for(self, path):
        if path not in self.files:
            self.files[path] = ProtoFile(path)
            self.order.append(path)
        return self.files[path]

    def wanted(self, decl):
        return not decl.builtIn() and (decl.mainFile() or self.include_all)

    def split_scope(self, scoped_name):
        """(module path, the rest) of a scoped name."""
        count = 0
        while count < len(scoped_name) - 1 and isinstance(
                idlast.findDecl(scoped_name[:count + 1]), idlast.Module):
            count += 1
        return scoped_name[:count], scoped_name[count:]

    def full_name(self, decl):
        modules, rest = self.split_scope(decl.scopedName())
        return ".".join(modules + ["_".join(rest)])

    def package_of(self, decl):
        return ".".join(self.split_scope(decl.scopedName())[0])

    def add_item(self, decl, item, full_name, what, scope_decl=None):
        """Adds a top-level item to the .proto of decl's file, checking package and name clashes.

        scope_decl (default decl) is the declaration whose module path gives the package."""
        proto = self.file_for(decl.file())
        package = self.package_of(scope_decl or decl)
        if proto.package is None:
            proto.package, proto.package_where = package, location(decl)
        elif proto.package != package and not proto.package_error:
            proto.package_error = True
            self.error(decl, "%s is in module '%s' but earlier declarations of %s are in module "
                       "'%s' (%s): a Planet schema file has one package; put each module path in "
                       "its own IDL file" % (what, package.replace(".", "::") or "(global scope)",
                                            os.path.basename(decl.file()),
                                            proto.package.replace(".", "::") or "(global scope)",
                                            proto.package_where))
        self.claim(decl, full_name, what)
        proto.items.append(item)
        return proto

    def claim(self, decl, full_name, what):
        if full_name in self.symbols:
            self.error(decl, "%s maps to the Protobuf name '%s', already used by %s; rename one "
                       "of them" % (what, full_name, self.symbols[full_name]))
        else:
            self.symbols[full_name] = "%s (%s)" % (what, location(decl))

    def require(self, proto, decl, by_option=False):
        """Imports the .proto of decl's IDL file into proto if it is another file.

        by_option: decl is only named in an option (raises), which protoc does not count as a
        use; such imports are made public so that protoc does not warn about them."""
        other = proto_file_name(decl.file())
        if other == proto.name:
            return
        if by_option:
            proto.option_imports.add(other)
        else:
            proto.imports.add(other)

    # --- types ------------------------------------------------------------------------------

    def map_type(self, idl_type, dims, msg, proto, where_decl, what):
        """Mapped for idl_type with extra array dims, or None after recording an error."""
        base, dims = resolve(idl_type, dims)
        if dims:
            dim_token = "x".join(str(d) for d in dims)
            if base.kind() == idltype.tk_octet:
                return Mapped("bytes", "octet", "Array%s_octet" % dim_token, dims=dims)
            item = self.map_type(base, [], msg, proto, where_decl, what)
            if item is None:
                return None
            token = "Array%s_%s" % (dim_token, item.token)
            if item.repeated:
                return Mapped(msg.wrapper(item), item.idl_with_dims(), token, True, dims)
            return Mapped(item.proto, item.idl, token, True, dims, item.bound)

        kind = base.kind()
        if kind in BASE_TYPES:
            proto_type, idl = BASE_TYPES[kind]
            return Mapped(proto_type, idl, idl.replace(" ", "_"))
        if kind in REFUSED_BASE:
            self.refuse(where_decl, what, *REFUSED_BASE[kind])
            return None
        if kind in (idltype.tk_string, idltype.tk_wstring):
            word = "string" if kind == idltype.tk_string else "wstring"
            bound = base.bound()
            idl = "%s<%d>" % (word, bound) if bound else word
            return Mapped("string", idl, word + (str(bound) if bound else ""), bound=bound)
        if kind == idltype.tk_sequence:
            bound = base.bound()
            suffix = ",%d" % bound if bound else ""
            element, element_dims = resolve(base.seqType(), [])
            if element.kind() == idltype.tk_octet and not element_dims:
                return Mapped("bytes", "sequence<octet%s>" % suffix,
                              "Seq%s_octet" % (bound or ""), bound=bound)
            item = self.map_type(base.seqType(), [], msg, proto, where_decl, what)
            if item is None:
                return None
            idl = "sequence<%s%s>" % (item.idl_with_dims(), suffix)
            token = "Seq%s_%s" % (bound or "", item.token)
            if item.repeated:
                return Mapped(msg.wrapper(item), idl, token, True, bound=bound)
            return Mapped(item.proto, idl, token, True, bound=bound)
        if kind == idltype.tk_fixed:
            self.refuse(where_decl, what, "'fixed<%d,%d>'" % (base.digits(), base.scale()),
                        REASON_FIXED)
            return None
        if kind in (idltype.tk_struct, idltype.tk_union, idltype.tk_enum, idltype.tk_except,
                    idltype.ot_structforward, idltype.ot_unionforward):
            decl = full_decl(base.decl())
            if decl is None:
                self.error(where_decl, "%s: '%s' is forward-declared but never defined"
                           % (what, colons(base.scopedName())))
                return None
            full = self.full_name(decl)
            self.require(proto, decl)
            return Mapped("." + full, "::" + colons(decl.scopedName()), full.replace(".", "_"))
        name = colons(base.scopedName()) if isinstance(base, idltype.Declared) else ""
        if kind == idltype.tk_objref:
            self.refuse(where_decl, what, "object reference '%s'" % name, REASON_OBJREF)
        elif kind == idltype.tk_abstract_interface:
            self.refuse(where_decl, what, "abstract interface '%s'" % name, REASON_ABSTRACT)
        elif kind == idltype.tk_local_interface:
            self.refuse(where_decl, what, "local interface '%s'" % name, REASON_LOCAL)
        elif kind in (idltype.tk_value, idltype.tk_value_box):
            self.refuse(where_decl, what, "valuetype '%s'" % name, REASON_VALUE)
        elif kind == idltype.tk_native:
            self.refuse(where_decl, what, "native '%s'" % name, REASON_NATIVE)
        else:
            self.refuse(where_decl, what, "type kind %s" % idltype.kind_map.get(kind, kind),
                        "no Planet equivalent")
        return None

    # --- declarations -----------------------------------------------------------------------

    def declaration(self, decl):
        if isinstance(decl, idlast.Module):
            for inner in decl.definitions():
                self.declaration(inner)
            return
        if not self.wanted(decl) or id(decl) in self.done:
            return
        self.done.add(id(decl))
        if isinstance(decl, (idlast.Struct, idlast.Exception)):
            self.struct(decl)
        elif isinstance(decl, idlast.Union):
            self.union(decl)
        elif isinstance(decl, idlast.Enum):
            self.enum(decl)
        elif isinstance(decl, idlast.Typedef):
            self.typedef(decl)
        elif isinstance(decl, idlast.Interface):
            self.interface(decl)
        elif isinstance(decl, idlast.Const):
            self.const(decl)
        elif isinstance(decl, (idlast.Forward, idlast.StructForward, idlast.UnionForward)):
            pass  # the full declaration carries everything
        elif isinstance(decl, idlast.Native):
            self.refuse(decl, "", "native '%s'" % colons(decl.scopedName()), REASON_NATIVE)
        elif isinstance(decl, (idlast.Value, idlast.ValueAbs, idlast.ValueBox,
                               idlast.ValueForward)):
            self.refuse(decl, "", "valuetype '%s'" % colons(decl.scopedName()), REASON_VALUE)
        else:
            self.refuse(decl, "", "IDL construct '%s'" % type(decl).__name__,
                        "no Planet equivalent")

    def inline_types(self, holder, constr):
        """Translates a struct/union/enum declared inline in a member, typedef or union case."""
        if constr:
            self.declaration(holder.decl())

    def struct(self, decl):
        is_exception = isinstance(decl, idlast.Exception)
        word = "exception" if is_exception else "struct"
        full = self.full_name(decl)
        msg = Message(self, full, "MESSAGE_KIND_EXCEPTION" if is_exception
                      else "MESSAGE_KIND_STRUCT", decl, decl.repoId())
        proto = self.add_item(decl, msg, full, "%s '%s'" % (word, colons(decl.scopedName())))
        number = 0
        for member in decl.members():
            self.inline_types(member.memberType(), member.constrType())
            for declarator in member.declarators():
                number += 1
                what = "member '%s' of %s '%s'" % (declarator.identifier(), word,
                                                   colons(decl.scopedName()))
                mapped = self.map_type(member.memberType(), declarator.sizes(), msg, proto,
                                       member, what)
                if mapped is not None:
                    msg.add_field(Field(declarator.identifier(), number, mapped, []), member)

    def union(self, decl):
        scoped = colons(decl.scopedName())
        full = self.full_name(decl)
        msg = Message(self, full, "MESSAGE_KIND_UNION", decl, decl.repoId())
        proto = self.add_item(decl, msg, full, "union '%s'" % scoped)
        self.inline_types(decl.switchType(), decl.constrType())
        discriminator = self.map_type(decl.switchType(), [], msg, proto, decl,
                                      "discriminator of union '%s'" % scoped)
        if discriminator is not None:
            msg.add_field(Field("discriminator", 1, discriminator,
                                [("discriminator", "true")]), decl)
        msg.oneof = ("branch", [])
        number = 1
        for case in decl.cases():
            self.inline_types(case.caseType(), case.constrType())
            declarator = case.declarator()
            number += 1
            name = declarator.identifier()
            if name == "discriminator":
                self.error(case, "branch 'discriminator' of union '%s' clashes with the "
                           "generated discriminator field; rename the branch" % scoped)
                continue
            mapped = self.map_type(case.caseType(), declarator.sizes(), msg, proto, case,
                                   "branch '%s' of union '%s'" % (name, scoped))
            if mapped is None:
                continue
            if mapped.repeated:  # a oneof member cannot be repeated: hold it in a wrapper
                mapped = Mapped(msg.wrapper(mapped), mapped.idl_with_dims(), mapped.token)
            options = []
            for label in case.labels():
                if label.default():
                    options.append(("default_case", "true"))
                else:
                    options.append(("case_labels", quote(self.label_text(label))))
            msg.add_field(Field(name, number, mapped, options), case, in_oneof=True)

    @staticmethod
    def label_text(label):
        value = label.value()
        if isinstance(value, idlast.Enumerator):
            return value.identifier()
        if label.labelKind() == idltype.tk_boolean:
            return "TRUE" if value else "FALSE"
        if label.labelKind() in (idltype.tk_char, idltype.tk_wchar):
            char = value if isinstance(value, str) else chr(value)
            return "'%s'" % char
        return str(value)

    def enum(self, decl):
        full = self.full_name(decl)
        item = Enum(full, decl.repoId())
        package = self.package_of(decl)
        what = "enum '%s'" % colons(decl.scopedName())
        self.add_item(decl, item, full, what)
        prefix = upper_snake(item.name) + "_"
        for enumerator in decl.enumerators():
            name = prefix + enumerator.identifier()
            # proto3 enum values are siblings of their enum in the package scope (C++ rules)
            self.claim(enumerator, (package + "." if package else "") + name,
                       "enumerator '%s' of %s" % (enumerator.identifier(), what))
            item.values.append((name, enumerator.value(), enumerator.identifier()))

    def typedef(self, decl):
        self.inline_types(decl.aliasType(), decl.constrType())
        # Nothing is generated (uses are resolved), but refused constructs are reported here too.
        scratch = Message(self, "typedef", "MESSAGE_KIND_WRAPPER", decl)
        proto = ProtoFile(decl.file())
        for declarator in decl.declarators():
            self.map_type(decl.aliasType(), declarator.sizes(), scratch, proto, decl,
                          "typedef '%s'" % colons(declarator.scopedName()))

    def const(self, decl):
        value = decl.value()
        if isinstance(value, idlast.Enumerator):
            value = value.identifier()
        proto = self.file_for(decl.file())
        proto.items.append("// IDL constant %s = %s (constants are not part of the schema)"
                           % (colons(decl.scopedName()), value))

    # --- interfaces -------------------------------------------------------------------------

    def callables(self, interface, callable_decl):
        """The Planet methods of one operation or attribute declared in interface."""
        if isinstance(callable_decl, idlast.Operation):
            params = [(p.identifier(), p.paramType(), p.direction(), p)
                      for p in callable_decl.parameters()]
            result = callable_decl.returnType()
            if result.kind() == idltype.tk_void:
                result = None
            return [Callable(callable_decl.identifier(), callable_decl, interface, params, result,
                             callable_decl.oneway(), callable_decl.raises(),
                             callable_decl.repoId(), None)]
        out = []
        for declarator in callable_decl.declarators():
            name = declarator.identifier()
            out.append(Callable("_get_" + name, callable_decl, interface, [],
                                callable_decl.attrType(), False, [], declarator.repoId(), name))
            if not callable_decl.readonly():
                out.append(Callable("_set_" + name, callable_decl, interface,
                                    [(name, callable_decl.attrType(), 0, callable_decl)], None,
                                    False, [], declarator.repoId(), name))
        return out

    def message_names(self, method):
        base = self.full_name(method.owner) + "_" + method.name
        return base + "_Request", base + "_Reply"

    def interface(self, decl):
        scoped = colons(decl.scopedName())
        if decl.local():
            self.refuse(decl, "", "local interface '%s'" % scoped, REASON_LOCAL)
            return
        if decl.abstract():
            self.refuse(decl, "", "abstract interface '%s'" % scoped, REASON_ABSTRACT)
            return
        for inner in decl.declarations():
            self.declaration(inner)
        full = self.full_name(decl)
        service = Service(decl.identifier(),
                          decl.repoId(), [full_decl(b).repoId() for b in decl.inherits()])
        # The service is listed after its messages: add the messages first.
        proto = self.file_for(decl.file())
        for callable_decl in decl.callables():
            for method in self.callables(decl, callable_decl):
                self.method_messages(method, proto)
        self.add_item(decl, service, full, "interface '%s'" % scoped)
        for callable_decl in decl.all_callables():
            owner = idlast.findDecl(self.callable_scope(callable_decl))
            for method in self.callables(owner, callable_decl):
                self.require(proto, owner)
                request, reply = self.message_names(method)
                options = [("method_repository_id", quote(method.repo_id))]
                if method.attribute:
                    options.append(("attribute", quote(method.attribute)))
                if method.oneway:
                    options.append(("oneway", "true"))
                for exception in method.raises:
                    self.require(proto, exception, by_option=True)
                    options.append(("raises", quote(self.full_name(exception))))
                service.methods.append((method.name, "." + request, "." + reply, options))

    @staticmethod
    def callable_scope(callable_decl):
        if isinstance(callable_decl, idlast.Operation):
            return callable_decl.scopedName()[:-1]
        return callable_decl.declarators()[0].scopedName()[:-1]

    def method_messages(self, method, proto):
        op_name = "%s::%s" % (colons(method.owner.scopedName()), method.name)
        what = "operation '%s'" % op_name
        decl = method.decl
        if isinstance(decl, idlast.Operation) and decl.contexts():
            self.refuse(decl, what, "a context clause", REASON_CONTEXT)
        request_name, reply_name = self.message_names(method)
        request = Message(self, request_name, "MESSAGE_KIND_REQUEST", decl)
        reply = Message(self, reply_name, "MESSAGE_KIND_REPLY", decl)
        self.add_item(decl, request, request_name, "the request of %s" % what, method.owner)
        self.add_item(decl, reply, reply_name, "the reply of %s" % what, method.owner)
        if method.result is not None:
            mapped = self.map_type(method.result, [], reply, proto, decl, "result of " + what)
            if mapped is not None:
                reply.add_field(Field("result", 1, mapped,
                                      [("param_mode", "PARAM_MODE_RETURN")]), decl)
        for position, (name, idl_type, direction, param_decl) in enumerate(method.params, 1):
            where = "parameter '%s' of %s" % (name, what)
            targets = []
            if direction in (0, 2):
                targets.append(request)
            if direction in (1, 2):
                if name == "result" and method.result is not None:
                    self.error(param_decl, "%s: an out/inout parameter named 'result' clashes "
                               "with the field carrying the return value; rename it" % where)
                    continue
                targets.append(reply)
            for msg in targets:
                mapped = self.map_type(idl_type, [], msg, proto, param_decl, where)
                if mapped is None:
                    break
                options = [("param_mode", MODE_NAMES[direction]),
                           ("param_position", str(position))]
                msg.add_field(Field(name, len(msg.fields) + 1, mapped, options), param_decl)
