#!/usr/bin/env bash
# Throw-away CA + certificates for Zenoh TLS / mutual TLS (tests and the demo; NOT for production).
#
#   scripts/make_certs.sh OUT_DIR [--san IP_OR_DNS]... [--client NAME]...
#
# Writes OUT_DIR/ca.pem + ca.key, OUT_DIR/router.pem + router.key (server certificate, CN=router,
# SANs localhost, 127.0.0.1 and every --san), and for each --client NAME (default: robot) a client
# certificate OUT_DIR/NAME.pem + NAME.key with CN=NAME (matched by access_control cert_common_names).
# Also writes OUT_DIR/rogue-ca.pem and OUT_DIR/rogue.pem + rogue.key: a certificate from ANOTHER CA,
# which a router must refuse. Keys are EC P-256, valid 30 days.
set -euo pipefail

usage() { echo "usage: $0 OUT_DIR [--san IP_OR_DNS]... [--client NAME]..." >&2; exit 2; }
[ $# -ge 1 ] || usage
out=$1; shift
sans=("DNS:localhost" "IP:127.0.0.1")
clients=()
while [ $# -gt 0 ]; do
  case $1 in
    --san) [ $# -ge 2 ] || usage
           if [[ $2 =~ ^[0-9.]+$ || $2 == *:* ]]; then sans+=("IP:$2"); else sans+=("DNS:$2"); fi; shift 2 ;;
    --client) [ $# -ge 2 ] || usage
              [[ $2 =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "$0: bad client name '$2'" >&2; exit 2; }
              clients+=("$2"); shift 2 ;;
    *) usage ;;
  esac
done
[ ${#clients[@]} -gt 0 ] || clients=(robot)
command -v openssl >/dev/null || { echo "$0: openssl not found (apt-get install openssl)" >&2; exit 1; }
mkdir -p "$out"
cd "$out"
umask 077
days=30

newkey() { openssl ecparam -name prime256v1 -genkey -noout 2>/dev/null | openssl pkcs8 -topk8 -nocrypt -out "$1"; }

make_ca() {  # name cn
  newkey "$1.key"
  openssl req -x509 -new -key "$1.key" -sha256 -days $days -subj "/CN=$2" -out "$1.pem" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
}

make_leaf() {  # name cn ca san usage
  newkey "$1.key"
  openssl req -new -key "$1.key" -subj "/CN=$2" -out "$1.csr" 2>/dev/null
  printf 'basicConstraints=critical,CA:FALSE\nkeyUsage=critical,digitalSignature\nextendedKeyUsage=%s\nsubjectAltName=%s\n' \
    "$5" "$4" > "$1.ext"
  openssl x509 -req -in "$1.csr" -CA "$3.pem" -CAkey "$3.key" -CAcreateserial -days $days -sha256 \
    -extfile "$1.ext" -out "$1.pem" 2>/dev/null
  rm -f "$1.csr" "$1.ext"
}

san=$(IFS=,; echo "${sans[*]}")
make_ca ca "zentf throw-away CA"
make_leaf router router ca "$san" "serverAuth,clientAuth"
for c in "${clients[@]}"; do
  make_leaf "$c" "$c" ca "DNS:$c,$san" "clientAuth,serverAuth"
done
make_ca rogue-ca "zentf rogue CA"
make_leaf rogue rogue rogue-ca "DNS:rogue,$san" "clientAuth,serverAuth"
rm -f ./*.srl
chmod 644 ./*.pem
echo "certificates in $(pwd): ca.pem router.pem ${clients[*]/%/.pem} rogue.pem (keys: *.key)"
