#!/usr/bin/env bash
# Writes kr's TLS files when there are none yet: a CA (ca.pem, ca.key) and the CAMUS server's
# certificate (server.pem, server.key; it names camus-server, localhost and 127.0.0.1, so that
# peers on the kr network and the health check on the container itself can verify it).
# deploy/images/build.sh runs it; compose gives them as the secrets kr-tls-ca, kr-tls-cert and
# kr-tls-key, and every Planet peer of kr speaks TLS 1.3 (docs/security.md).
#   compose/make-certs.sh [DIR]    (default: ${URS_KR_TLS_DIR:-compose/config/kr-tls})
# The containers run as user 10001 and read the files through bind mounts, so they stay readable
# by others (0644), like the token (compose/make-token.sh): keep them on a host, or in a folder,
# that only the space's operators can read. Delete the folder to make new ones.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=${1:-${URS_KR_TLS_DIR:-$here/config/kr-tls}}
[[ -s "$dir/server.pem" && -s "$dir/server.key" && -s "$dir/ca.pem" ]] && exit 0
mkdir -p "$dir"
umask 022
ec=(-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes)
openssl req -x509 "${ec[@]}" -days 3650 -subj /CN=kr-ca -keyout "$dir/ca.key" -out "$dir/ca.pem" 2>/dev/null
openssl req "${ec[@]}" -subj /CN=camus-server -keyout "$dir/server.key" -out "$dir/server.csr" 2>/dev/null
printf 'subjectAltName=DNS:camus-server,DNS:localhost,IP:127.0.0.1\n' >"$dir/san.cnf"
openssl x509 -req -in "$dir/server.csr" -CA "$dir/ca.pem" -CAkey "$dir/ca.key" -CAcreateserial -days 825 \
  -extfile "$dir/san.cnf" -out "$dir/server.pem" 2>/dev/null
chmod 0644 "$dir/server.key"   # read by user 10001 in the container (see above)
chmod 0600 "$dir/ca.key"       # never mounted
rm -f "$dir/server.csr" "$dir/san.cnf"
echo "compose: wrote a new CA and server certificate for kr to $dir"
