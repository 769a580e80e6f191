# omniidl back-end: CORBA IDL -> Planet schema (one proto3 file per IDL file).
#
#   omniidl -p <this directory> -b planet_proto [-K] [-C <output dir>] [-Wball] <file.idl>...
#
# The mapping rules, and what is refused, are in docs/idl-mapping.md. On any refused construct
# every error is printed as "<file>:<line>: error: ..." and omniidl exits with status 1 without
# writing any .proto for that IDL file. Output goes to the current directory (omniidl's -C).
"""Planet schema (Protobuf) back-end for omniidl."""

import sys

import planet_translator

usage_string = """\
  -Wball    also translate every #included IDL file that contributes declarations
            (default: only the files named on the command line)
  Pass -K to omniidl to copy the IDL comments into the generated .proto files."""


def run(tree, args):
    include_all = False
    for arg in args:
        if arg == "all":
            include_all = True
        else:
            sys.stderr.write("omniidl planet_proto: unknown back-end option '-Wb%s' "
                             "(known: -Wball)\n" % arg)
            sys.exit(2)

    translator = planet_translator.Translator(include_all)
    translator.translate(tree)
    errors = translator.finish()
    if errors:
        for error in errors:
            sys.stderr.write(error + "\n")
        sys.stderr.write("omniidl planet_proto: %d error(s) in %s; no .proto written\n"
                         % (len(errors), tree.file()))
        sys.stderr.flush()
        sys.exit(1)
    for name, text in translator.outputs():
        with open(name, "w", encoding="utf-8") as out:
            out.write(text)
