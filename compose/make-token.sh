#!/usr/bin/env bash
# Writes a space's token when there is none yet: 32 random bytes, base64. deploy/images/build.sh
# runs it for kr's Planet token (compose secret kr-token), kr's operators' token (secret
# kr-operator-token, config/kr-credentials.yaml) and jp's gateway credential (secret jp-token), so
# `docker-compose up` finds every file.
#   compose/make-token.sh [FILE]    (default: ${URS_KR_TOKEN_FILE:-compose/config/kr.token})
# The containers run as user 10001 and read the file through a bind mount, so it stays readable
# by others (0644): keep it on a host, or in a folder, that only the space's operators can read.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
file=${1:-${URS_KR_TOKEN_FILE:-$here/config/kr.token}}
[[ -s "$file" ]] && exit 0
umask 022
head -c 32 /dev/urandom | base64 >"$file"
echo "compose: wrote a new token to $file"
