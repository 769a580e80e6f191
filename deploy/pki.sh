#!/usr/bin/env bash
# The federation's PKI: one CA whose certificates let a space's bridge join the secured DDS link
# (DDS-Security: DDS:Auth:PKI-DH, DDS:Access:Permissions, DDS:Crypto:AES-GCM-GMAC), and the signed
# governance and permissions documents the link's participants enforce. docs/federation.md,
# "A secured link", tells how two sites use it.
#
#   deploy/pki.sh init DIR [--name NAME] [--days N]
#       the federation CA: DIR/ca.pem, DIR/ca.key (EC P-256), its database and an empty CRL
#   deploy/pki.sh governance DIR [--protection encrypt|sign] [--domains MIN-MAX]
#       DIR/governance.xml and its signed form DIR/governance.p7s: unauthenticated participants
#       refused, join access control on, discovery, liveliness and data protected (encrypted, or
#       only signed where a site must inspect its traffic)
#   deploy/pki.sh member DIR SPACE [--calls SPACES] [--callers SPACES] [--reads SPACES] [--days N]
#                                  [--domains MIN-MAX]
#       SPACE's identity (CN=SPACE) in DIR/SPACE/identity.{pem,key} and its permissions in
#       DIR/SPACE/permissions.{xml,p7s}: SPACE may write the catalog, interfaces and state
#       (urs/catalog, urs/interface, urs/state/*) only in the DDS partition SPACE, read them in the
#       partitions of --reads (comma-separated spaces, '*' for all, the default; its own always),
#       read the requests addressed to it and the replies to its own calls, call the spaces of
#       --calls (comma-separated, '*' for all; default none) and answer those of --callers
#       (default '*'). DDS itself then refuses a member writing another space's partition or
#       reading one it was not granted (docs/security.md)
#   deploy/pki.sh tls DIR NAME [--san SAN]
#       a Planet TLS certificate from the same CA: DIR/tls/NAME.{pem,key} (SAN e.g. "DNS:camus-server,IP:127.0.0.1")
#   deploy/pki.sh revoke DIR SPACE
#       revokes SPACE's identity and rewrites DIR/crl.pem (give it to every member's bridge)
#   deploy/pki.sh check DIR SPACE
#       checks SPACE's files as its bridge will use them: the identity signed by the CA, in its
#       validity and not revoked, the key matching it, the documents signed by the CA, and the
#       permissions naming the identity's subject and granting the shared topics in partition
#       SPACE; prints each problem and exits 1 on any
#
# The CA key signs everything: keep DIR/ca.key off the hosts that run bridges. A site joining the
# federation sends nothing secret: the federation's operator runs `member` and hands over
# DIR/ca.pem, DIR/governance.p7s, DIR/crl.pem and the folder DIR/SPACE.
set -euo pipefail

die() { echo "pki: $*" >&2; exit 1; }
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//' >&2; exit 2; }

subject_of() {  # the subject of a certificate, in RFC 2253 order as the permissions must name it
  openssl x509 -in "$1" -noout -subject -nameopt RFC2253 | sed 's/^subject=//'
}

# DDS-Security wants dates as YYYY-MM-DDTHH:MM:SS (UTC).
dds_date() { date -u -d "$1" +%Y-%m-%dT%H:%M:%S; }

sign() {  # $1 = XML file; writes $1 with .p7s for .xml, S/MIME signed by the CA (clear text kept)
  local dir=$1 xml=$2
  openssl smime -sign -in "$xml" -text -out "${xml%.xml}.p7s" -signer "$dir/ca.pem" -inkey "$dir/ca.key" 2>/dev/null ||
    die "cannot sign $xml with $dir/ca.key"
}

ca_config() {  # the openssl ca configuration of DIR
  local dir=$1
  cat >"$dir/ca.cnf" <<EOF
[ ca ]
default_ca = federation
[ federation ]
dir = $dir
database = \$dir/index.txt
new_certs_dir = \$dir/issued
serial = \$dir/serial
crlnumber = \$dir/crlnumber
certificate = \$dir/ca.pem
private_key = \$dir/ca.key
default_md = sha256
default_crl_days = 365
policy = anything
unique_subject = no
copy_extensions = copy
[ anything ]
organizationName = optional
commonName = supplied
EOF
}

domains_xml() {  # MIN-MAX
  local min=${1%-*} max=${1#*-}
  [[ "$min" =~ ^[0-9]+$ && "$max" =~ ^[0-9]+$ && $min -le $max && $max -le 232 ]] ||
    die "--domains takes MIN-MAX within 0-232, not '$1'"
  printf '<domains><id_range><min>%s</min><max>%s</max></id_range></domains>' "$min" "$max"
}

topics_xml() {  # topic expressions, one <topic> each
  local t
  for t in "$@"; do printf '<topic>%s</topic>' "$t"; done
}

partitions_xml() {  # partition names, one <partition> each
  local p
  for p in "$@"; do printf '<partition>%s</partition>' "$p"; done
}

space_list() {  # "a,b" or "*" -> the spaces, one per line; checks each name
  local list=$1 s
  [[ -z "$list" ]] && return 0
  IFS=',' read -ra spaces <<<"$list"
  for s in "${spaces[@]}"; do
    [[ "$s" == "*" || "$s" =~ ^[A-Za-z0-9_.-]+$ ]] || die "'$s' is not a space name"
    echo "$s"
  done
}

cmd_init() {
  local dir=$1 name=federation-ca days=3650
  shift
  while (($#)); do
    case $1 in
      --name) name=$2; shift 2 ;;
      --days) days=$2; shift 2 ;;
      *) usage ;;
    esac
  done
  [[ -e "$dir/ca.key" ]] && die "$dir already holds a CA (ca.key); delete the folder to make a new one"
  mkdir -p "$dir/issued"
  umask 077
  openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days "$days" \
    -subj "/O=URSLink federation/CN=$name" -keyout "$dir/ca.key" -out "$dir/ca.pem" 2>/dev/null ||
    die "openssl could not make the CA"
  chmod 0644 "$dir/ca.pem"
  : >"$dir/index.txt"
  echo 1000 >"$dir/serial"
  echo 1000 >"$dir/crlnumber"
  ca_config "$dir"
  write_crl "$dir"
  echo "pki: federation CA $(subject_of "$dir/ca.pem") in $dir"
}

write_crl() {
  local dir=$1
  openssl ca -config "$dir/ca.cnf" -gencrl -out "$dir/crl.pem" 2>/dev/null || die "cannot write $dir/crl.pem"
  chmod 0644 "$dir/crl.pem"
}

cmd_governance() {
  local dir=$1 protection=ENCRYPT domains=0-232
  shift
  while (($#)); do
    case $1 in
      --protection)
        case $2 in encrypt) protection=ENCRYPT ;; sign) protection=SIGN ;; *) die "--protection is encrypt or sign" ;; esac
        shift 2 ;;
      --domains) domains=$2; shift 2 ;;
      *) usage ;;
    esac
  done
  [[ -s "$dir/ca.key" ]] || die "$dir holds no CA: run 'pki.sh init $dir' first"
  cat >"$dir/governance.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      $(domains_xml "$domains")
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>$protection</discovery_protection_kind>
      <liveliness_protection_kind>$protection</liveliness_protection_kind>
      <rtps_protection_kind>$protection</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>urs/*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>$protection</metadata_protection_kind>
          <data_protection_kind>$protection</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
  sign "$dir" "$dir/governance.xml"
  echo "pki: governance ($protection) in $dir/governance.p7s"
}

cmd_member() {
  local dir=$1 space=$2 calls="" callers="*" reads="*" days=825 domains=0-232
  shift 2
  while (($#)); do
    case $1 in
      --calls) calls=$2; shift 2 ;;
      --reads) reads=$2; shift 2 ;;
      --callers) callers=$2; shift 2 ;;
      --days) days=$2; shift 2 ;;
      --domains) domains=$2; shift 2 ;;
      *) usage ;;
    esac
  done
  [[ "$space" =~ ^[A-Za-z0-9_.-]+$ ]] || die "'$space' is not a space name"
  [[ -s "$dir/ca.key" ]] || die "$dir holds no CA: run 'pki.sh init $dir' first"
  local out=$dir/$space
  mkdir -p "$out"
  (
    umask 077
    openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj "/O=URSLink federation/CN=$space" \
      -keyout "$out/identity.key" -out "$out/identity.csr" 2>/dev/null
  ) || die "openssl could not make $space's key"
  openssl ca -batch -config "$dir/ca.cnf" -days "$days" -in "$out/identity.csr" -out "$out/identity.pem" \
    -notext 2>"$out/ca.log" || die "the CA refused $space: $(cat "$out/ca.log")"
  rm -f "$out/identity.csr" "$out/ca.log"
  chmod 0644 "$out/identity.key"  # read by the bridge's user in its container, as compose's TLS key
  local subject not_before not_after
  subject=$(subject_of "$out/identity.pem")
  not_before=$(dds_date "$(openssl x509 -in "$out/identity.pem" -noout -startdate | cut -d= -f2)")
  not_after=$(dds_date "$(openssl x509 -in "$out/identity.pem" -noout -enddate | cut -d= -f2)")

  # What SPACE may write and read. Requests go to urs/rpc/<callee>/request, replies to
  # urs/rpc/<caller>/reply (docs/federation.md), in the default partition. A space always reads
  # its own request and reply topics (its link opens them at start); what it may write decides
  # whom it calls and whom it answers. The shared topics have a rule of their own: Fast DDS checks
  # an endpoint's partitions against every partition of the first rule naming its topic.
  local shared=(urs/catalog urs/interface "urs/state/*")
  local rpc_publish=() rpc_subscribe=("urs/rpc/$space/request" "urs/rpc/$space/reply")
  local read_partitions=() s
  while read -r s; do [[ -n "$s" ]] && rpc_publish+=("urs/rpc/$s/request"); done < <(space_list "$calls")
  while read -r s; do [[ -n "$s" ]] && rpc_publish+=("urs/rpc/$s/reply"); done < <(space_list "$callers")
  while read -r s; do [[ -n "$s" ]] && read_partitions+=("$s"); done < <(space_list "$reads")
  ((${#read_partitions[@]})) || die "--reads takes at least one space (or '*')"
  [[ " ${read_partitions[*]} " == *" * "* ]] && read_partitions=("*")
  [[ "${read_partitions[*]}" == "*" || " ${read_partitions[*]} " == *" $space "* ]] || read_partitions+=("$space")
  local rpc_rule
  rpc_rule="<subscribe><topics>$(topics_xml "${rpc_subscribe[@]}")</topics></subscribe>"
  ((${#rpc_publish[@]})) && rpc_rule="<publish><topics>$(topics_xml "${rpc_publish[@]}")</topics></publish>$rpc_rule"
  cat >"$out/permissions.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$space">
      <subject_name>$subject</subject_name>
      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>
      <allow_rule>
        $(domains_xml "$domains")
        $rpc_rule
      </allow_rule>
      <allow_rule>
        $(domains_xml "$domains")
        <publish><topics>$(topics_xml "${shared[@]}")</topics><partitions>$(partitions_xml "$space")</partitions></publish>
        <subscribe><topics>$(topics_xml "${shared[@]}")</topics><partitions>$(partitions_xml "${read_partitions[@]}")</partitions></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  sign "$dir" "$out/permissions.xml"
  echo "pki: $space: identity $subject until $not_after; calls [${calls:-none}], answers [${callers:-none}]," \
    "reads [$(IFS=,; echo "${read_partitions[*]}")] in $out"
}

cmd_tls() {
  local dir=$1 name=$2 san=""
  shift 2
  while (($#)); do
    case $1 in
      --san) san=$2; shift 2 ;;
      *) usage ;;
    esac
  done
  [[ -s "$dir/ca.key" ]] || die "$dir holds no CA: run 'pki.sh init $dir' first"
  mkdir -p "$dir/tls"
  (
    umask 077
    openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj "/O=URSLink federation/CN=$name" \
      -keyout "$dir/tls/$name.key" -out "$dir/tls/$name.csr" 2>/dev/null
  ) || die "openssl could not make $name's key"
  local extensions=()
  if [[ -n "$san" ]]; then
    printf 'subjectAltName=%s\n' "$san" >"$dir/tls/$name.ext"
    extensions=(-extfile "$dir/tls/$name.ext")
  fi
  openssl x509 -req -in "$dir/tls/$name.csr" -CA "$dir/ca.pem" -CAkey "$dir/ca.key" -CAcreateserial -days 825 \
    "${extensions[@]}" -out "$dir/tls/$name.pem" 2>/dev/null || die "cannot sign $name's certificate"
  rm -f "$dir/tls/$name.csr" "$dir/tls/$name.ext"
  chmod 0644 "$dir/tls/$name.key"
  echo "pki: TLS certificate $(subject_of "$dir/tls/$name.pem") in $dir/tls/$name.pem"
}

cmd_revoke() {
  local dir=$1 space=$2
  [[ -s "$dir/$space/identity.pem" ]] || die "$dir/$space/identity.pem does not exist"
  openssl ca -config "$dir/ca.cnf" -revoke "$dir/$space/identity.pem" 2>"$dir/revoke.log" ||
    grep -q "already revoked" "$dir/revoke.log" || die "cannot revoke $space: $(cat "$dir/revoke.log")"
  rm -f "$dir/revoke.log"
  write_crl "$dir"
  echo "pki: $space revoked; give $dir/crl.pem to every member's bridge"
}

cmd_check() {
  local dir=$1 space=$2 problems=0
  local out=$dir/$space
  problem() { echo "pki: $space: $*" >&2; problems=$((problems + 1)); }
  local f
  for f in "$dir/ca.pem" "$dir/governance.p7s" "$out/identity.pem" "$out/identity.key" "$out/permissions.p7s"; do
    [[ -r "$f" ]] || problem "$f is missing or unreadable"
  done
  ((problems == 0)) || exit 1
  local crl=()
  [[ -s "$dir/crl.pem" ]] && crl=(-crl_check -CRLfile "$dir/crl.pem")
  openssl verify -CAfile "$dir/ca.pem" "${crl[@]}" "$out/identity.pem" >/dev/null 2>"$dir/.verify" ||
    problem "identity.pem does not verify against ca.pem: $(grep -m1 'error' "$dir/.verify" || cat "$dir/.verify")"
  rm -f "$dir/.verify"
  openssl x509 -in "$out/identity.pem" -noout -checkend 0 >/dev/null || problem "identity.pem has expired"
  [[ "$(openssl x509 -in "$out/identity.pem" -noout -pubkey)" == "$(openssl pkey -in "$out/identity.key" -pubout)" ]] ||
    problem "identity.key is not the key of identity.pem"
  local doc
  for doc in "$dir/governance.p7s" "$out/permissions.p7s"; do
    openssl smime -verify -in "$doc" -CAfile "$dir/ca.pem" -out /dev/null 2>/dev/null ||
      problem "$(basename "$doc") is not signed by the federation CA"
  done
  local subject named
  subject=$(subject_of "$out/identity.pem")
  named=$(openssl smime -verify -in "$out/permissions.p7s" -CAfile "$dir/ca.pem" 2>/dev/null |
    sed -n 's:.*<subject_name>\(.*\)</subject_name>.*:\1:p')
  [[ "$named" == "$subject" ]] ||
    problem "permissions name '$named', but identity.pem's subject is '$subject' (RFC 2253 order)"
  openssl smime -verify -in "$out/permissions.p7s" -CAfile "$dir/ca.pem" 2>/dev/null |
    grep -qF "<partitions><partition>$space</partition></partitions></publish>" ||
    problem "permissions do not let $space write the catalog and state in its partition $space" \
      "(made before partitions?): run 'pki.sh member' again"
  ((problems == 0)) || exit 1
  echo "pki: $space: ok ($subject)"
}

(($# >= 2)) || usage
command=$1
dir=$(realpath -m "$2")
shift 2
case $command in
  init) cmd_init "$dir" "$@" ;;
  governance) cmd_governance "$dir" "$@" ;;
  member) (($# >= 1)) || usage; cmd_member "$dir" "$@" ;;
  tls) (($# >= 1)) || usage; cmd_tls "$dir" "$@" ;;
  revoke) (($# == 1)) || usage; cmd_revoke "$dir" "$1" ;;
  check) (($# == 1)) || usage; cmd_check "$dir" "$1" ;;
  *) usage ;;
esac
