"""python3 -m planet --server HOST:PORT --token-file FILE [options]: see checks.py and docs/planet.md."""
import argparse
import sys


def read_token(path):
    with open(path) as f:
        return f.read().strip()


def main():
    parser = argparse.ArgumentParser(prog="python3 -m planet",
                                     description="Checks a Planet server against docs/planet.md")
    parser.add_argument("--server", required=True, help="HOST:PORT of the server")
    parser.add_argument("--token-file", help="token of a credential (role client, ideally); none for an open server")
    parser.add_argument("--sam-token-file", help="token of a credential with role sam (registration checks)")
    parser.add_argument("--operator-token-file", help="token of a credential with role operator (context checks)")
    parser.add_argument("--diag", default="diag", help="name of a URS.Diagnostic service in the space ('' = none)")
    parser.add_argument("--limit", action="append", default=[], metavar="NAME=VALUE",
                        help="a server limit other than the default (max_topic_bytes, max_topic_levels, "
                             "max_subscriptions_per_session, max_pending_calls_per_session, max_hello_bytes)")
    parser.add_argument("--handshake-timeout-s", type=float, default=10.0,
                        help="how long to wait for the server to give up on a silent client")
    parser.add_argument("--only", help="run the checks whose name matches this regular expression")
    parser.add_argument("--tls-ca", help="speak TLS 1.3, verifying the server against these CAs (PEM)")
    parser.add_argument("--tls-cert", help="client certificate (PEM) for mutual TLS, with --tls-key")
    parser.add_argument("--tls-key", help="private key of --tls-cert")
    parser.add_argument("--pythonpath", default="", help="colon-separated folders holding planet_pb2 and camus_pb2")
    args = parser.parse_args()
    sys.path[:0] = [p for p in args.pythonpath.split(":") if p]
    from . import checks

    limits = {"max_topic_bytes": 512, "max_topic_levels": 32, "max_subscriptions_per_session": 1000,
              "max_pending_calls_per_session": 1000, "max_hello_bytes": 4096}
    for item in args.limit:
        name, _, value = item.partition("=")
        if name not in limits or not value.isdigit():
            parser.error("--limit %s: expected one of %s with a number" % (item, ", ".join(limits)))
        limits[name] = int(value)
    tokens = {"client": read_token(args.token_file) if args.token_file else ""}
    if args.sam_token_file:
        tokens["sam"] = read_token(args.sam_token_file)
    if args.operator_token_file:
        tokens["operator"] = read_token(args.operator_token_file)
    host, _, port = args.server.rpartition(":")
    tls = None
    if args.tls_ca or args.tls_cert:
        import ssl
        tls = ssl.create_default_context(cafile=args.tls_ca)
        tls.minimum_version = ssl.TLSVersion.TLSv1_3
        if args.tls_cert:
            tls.load_cert_chain(args.tls_cert, args.tls_key)
    suite = checks.Suite(host, int(port), tokens, args.diag, limits, args.handshake_timeout_s, tls)
    ok = checks.run(suite, only=args.only, out=lambda line: print(line, flush=True))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
