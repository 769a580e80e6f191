#!/usr/bin/env python3
"""Writes a C++ file defining the bytes of a serialized FileDescriptorSet (urs::schema)."""
import sys

data = open(sys.argv[1], "rb").read()
rows = ",\n".join(", ".join(str(b) for b in data[i:i + 24]) for i in range(0, len(data), 24))
with open(sys.argv[2], "w") as out:
    out.write("// Generated from %s by embed_descriptor_set.py; do not edit.\n" % sys.argv[1].split("/")[-1])
    out.write("#include <cstddef>\n\nnamespace urs::schema {\n")
    out.write("extern const unsigned char kCompiledInterfaces[] = {\n%s};\n" % rows)
    out.write("extern const std::size_t kCompiledInterfacesSize = %d;\n}  // namespace urs::schema\n" % len(data))
