#!/usr/bin/python3
"""What a schema cannot see in a rendered overlay (kubectl kustomize deploy/k8s/overlays/SPACE):
every Secret and ConfigMap key a pod mounts exists (the Secrets: deploy/k8s/make-secrets.sh SPACE);
every address a service is given (HOST:PORT variables, the bridges' DDS peers) is a Service of the
namespace; each workload's environment is its compose service's; every container is hardened as in
compose, probed and sized; the link policy selects exactly the link members.

    k8s_references.py SOURCE_DIR SPACE RENDERED.yaml SECRETS.yaml
Prints each problem; exit 1 on any.
"""

import subprocess
import sys
from pathlib import Path

import yaml


def main():
    root, space, rendered, secrets = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3]), Path(sys.argv[4])
    objects = [o for o in yaml.safe_load_all(rendered.read_text()) if o]
    objects += [o for o in yaml.safe_load_all(secrets.read_text()) if o]
    compose = yaml.safe_load(subprocess.run([str(root / "deploy/services/urs-services"), "compose"], check=True,
                                            capture_output=True, text=True).stdout)
    description = yaml.safe_load((root / "deploy/services/services.yaml").read_text())
    problems = []
    by_kind = {}
    for o in objects:
        by_kind.setdefault(o["kind"], {})[o["metadata"]["name"]] = o
    namespace = f"urslink-{space}"
    for o in objects:
        if o["kind"] != "Namespace" and o["metadata"].get("namespace") != namespace:
            problems.append(f"{o['kind']} {o['metadata']['name']}: namespace {o['metadata'].get('namespace')}, not {namespace}")
    services = by_kind.get("Service", {})
    workloads = {**by_kind.get("Deployment", {}), **by_kind.get("StatefulSet", {})}

    # Which compose service each workload is: a pod's name, or the compose name its k8s_name stands for.
    compose_name = {}
    for name, svc in description["spaces"][space]["services"].items():
        if not description["roles"][svc["role"]].get("tool"):
            compose_name[svc.get("k8s_name", name)] = name
    if set(workloads) != set(compose_name):
        problems.append(f"workloads {sorted(workloads)}, the space's services {sorted(compose_name)}")

    def data_keys(kind, name):
        o = by_kind.get(kind, {}).get(name)
        if o is None:
            return None
        return set(o.get("data", {})) | set(o.get("binaryData", {}))

    link_members = set()
    for name, w in workloads.items():
        where = f"{w['kind']} {name}"
        pod = w["spec"]["template"]
        spec = pod["spec"]
        if pod["metadata"]["labels"].get("urslink.io/link") == "member":
            link_members.add(name)
        security = spec.get("securityContext", {})
        if not security.get("runAsNonRoot") or security.get("runAsUser") != 10001:
            problems.append(f"{where}: the pod does not run as the non-root user 10001")
        for volume in spec.get("volumes", []):
            sources = volume.get("projected", {}).get("sources", [])
            if "configMap" in volume:
                sources = [{"configMap": volume["configMap"]}]
            if "secret" in volume:
                sources = [{"secret": {"name": volume["secret"]["secretName"], **volume["secret"]}}]
            for source in sources:
                for kind, ref in (("ConfigMap", source.get("configMap")), ("Secret", source.get("secret"))):
                    if not ref:
                        continue
                    keys = data_keys(kind, ref["name"])
                    if keys is None:
                        problems.append(f"{where}: volume {volume['name']} mounts {kind} {ref['name']}, which does not exist")
                        continue
                    for item in ref.get("items", []):
                        if item["key"] not in keys:
                            problems.append(f"{where}: {kind} {ref['name']} has no key {item['key']}")
        for c in spec["containers"]:
            cw = f"{where} container {c['name']}"
            sc = c.get("securityContext", {})
            if sc.get("readOnlyRootFilesystem") is not True or sc.get("allowPrivilegeEscalation") is not False or \
                    sc.get("capabilities", {}).get("drop") != ["ALL"]:
                problems.append(f"{cw}: not read-only, without privilege gain and capabilities (compose's hardening)")
            if "readinessProbe" not in c:
                problems.append(f"{cw}: no readiness probe")
            if not c.get("resources", {}).get("requests", {}).get("memory") or \
                    not c.get("resources", {}).get("limits", {}).get("memory"):
                problems.append(f"{cw}: no memory request and limit")
            mounts = {m["mountPath"] for m in c.get("volumeMounts", [])}
            if "/tmp" not in mounts:
                problems.append(f"{cw}: no writable /tmp")
            env = {e["name"]: e.get("value") for e in c.get("env", [])}
            compose_service = compose["services"].get(compose_name.get(name, name), {})
            expected = dict(compose_service.get("environment", {}))
            expected["URS_LOG_LEVEL"] = "info"
            expected.pop("URS_METRICS_LISTEN", None)  # compose's metrics endpoint: the manifests declare none yet
            if w["kind"] == "StatefulSet" and compose_service.get("hostname") and "URS_HOST_CONTEXT" in env:
                expected["URS_HOST_CONTEXT"] = compose_service["hostname"]
            if env != {k: str(v) for k, v in expected.items()}:
                problems.append(f"{cw}: environment {env}, compose's {expected}")
            # Every HOST:PORT it is given names a Service of the namespace.
            for var in ("URS_SERVER", "URS_NAMING"):
                host = (env.get(var) or "").split(":")[0]
                if host and host not in services:
                    problems.append(f"{cw}: {var}={env[var]}, but there is no Service {host}")
            for peer in (env.get("URS_DDS_PEERS") or "").split():
                if peer.split(":")[0] not in services:
                    problems.append(f"{cw}: DDS peer {peer} is not a Service of the namespace")
    # The bridges' configuration: their initial peers are Services here too.
    for name, cm in by_kind.get("ConfigMap", {}).items():
        for key, text in cm.get("data", {}).items():
            config = yaml.safe_load(text) or {}
            for peer in (config.get("dds") or {}).get("initial_peers", []) if isinstance(config, dict) else []:
                if str(peer).split(":")[0] not in services:
                    problems.append(f"ConfigMap {name} {key}: DDS initial peer {peer} is not a Service of the namespace")
    # The link policy: exactly the bridge and the gateway are its members.
    link = by_kind.get("NetworkPolicy", {}).get("link")
    if link is None:
        problems.append("no NetworkPolicy link")
    expected_members = {n for n, s in compose_name.items()
                        if description["roles"][description["spaces"][space]["services"][s]["role"]].get("link")}
    if link_members != expected_members:
        problems.append(f"link members {sorted(link_members)}, the description's {sorted(expected_members)}")
    if "default-deny" not in by_kind.get("NetworkPolicy", {}):
        problems.append("no default-deny NetworkPolicy")
    for problem in problems:
        print(f"k8s_references {space}: {problem}")
    if not problems:
        print(f"k8s_references {space}: {len(objects)} objects; every mount, address, environment, hardening and the link "
              f"policy check out")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
