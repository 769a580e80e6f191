#!/bin/sh
# Regenerates the Planet modules of the Python SDK (python/urslink/_proto/*_pb2.py) from the
# project's .proto files with protoc (Debian's protobuf-compiler 3.21, matching python3-protobuf).
# They are committed, so `pip install ./python` needs no protoc; the python_sdk_generated test
# fails when they differ from what this script writes.
#   python/generate_proto.sh [OUT_DIR]      (default: python/urslink/_proto)
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
out=${1:-$here/urslink/_proto}
mkdir -p "$out"
protoc --python_out="$out" -I "$root/services/lib/planet/proto" -I "$root/idl" \
  "$root/services/lib/planet/proto/planet.proto" "$root/services/lib/planet/proto/camus.proto" \
  "$root/idl/urs_options.proto"
