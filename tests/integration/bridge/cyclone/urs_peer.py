"""A second DDS vendor on URSLink's link: Eclipse Cyclone DDS through its Python binding.

The types are written here from idl/dds/Federation.idl as any third party would write them, with
the QoS docs/federation.md gives. Each command prints one line per event on stdout, flushed, for
the test driving it:

  replier DOMAIN SPACE     serves calls to SPACE (urs/rpc/SPACE/request): every request is
                           answered with its own payload; prints "ready", then
                           "executed <request id>" per request it executes
  catalog DOMAIN           reads urs/catalog; prints "matched <n>" when the number of matched
                           writers changes and "entry <space>/<name>" per sample
  offer DOMAIN SPACE SERVICE DESCRIPTOR_SET_FILE LEASE_MS
                           offers SERVICE of SPACE as a bridge would: its description (the
                           FileDescriptorSet in the file) on urs/interface, its entry on
                           urs/catalog, both written again every second (a manual-by-topic writer
                           asserts its liveliness by writing), and serves its calls as `replier`
"""

import hashlib
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Listener, Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import key
from cyclonedds.idl.types import sequence, uint8, uint32, int32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class ServiceEntry(IdlStruct, typename="urs::dds::ServiceEntry"):
    space: str
    key("space")
    name: str
    key("name")
    interface_name: str
    repository_id: str
    origin: str
    bridge: str
    deadline_ms: uint32
    interface_digest: str


@dataclass
class InterfaceDescription(IdlStruct, typename="urs::dds::InterfaceDescription"):
    digest: str
    key("digest")
    descriptor_set: sequence[uint8]


@dataclass
class CallRequest(IdlStruct, typename="urs::dds::CallRequest"):
    request_id: str
    key("request_id")
    caller_space: str
    service: str
    operation: str
    deadline_ms: uint32
    no_reply: bool
    payload: sequence[uint8]
    caller_name: str
    traceparent: str


@dataclass
class CallReply(IdlStruct, typename="urs::dds::CallReply"):
    request_id: str
    key("request_id")
    status: int32
    message: str
    exception_type: str
    payload: sequence[uint8]


def say(*words):
    print(*words, flush=True)


# Requests and replies: reliable, transient-local, keep-last 1 per request (docs/federation.md).
RPC_QOS = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
              Policy.History.KeepLast(1))
# Reading the catalog: as above (and any liveliness its writers offer).
CATALOG_QOS = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
                  Policy.History.KeepLast(1))


class Replier:
    """Serves calls to SPACE: every request is answered with its own payload."""

    def __init__(self, participant, space):
        self.participant = participant
        self.requests = DataReader(participant, Topic(participant, f"urs/rpc/{space}/request", CallRequest),
                                   qos=RPC_QOS)
        self.writers = {}

    def serve(self):
        """Serves the requests that arrive within a second."""
        for request in self.requests.take_iter(timeout=duration(seconds=1)):
            if not request.sample_info.valid_data:
                continue  # its caller no longer waits for it
            say("executed", request.request_id)
            if request.no_reply:
                continue
            caller = request.caller_space
            if caller not in self.writers:
                topic = Topic(self.participant, f"urs/rpc/{caller}/reply", CallReply)
                self.writers[caller] = DataWriter(self.participant, topic, qos=RPC_QOS)
            self.writers[caller].write(CallReply(request_id=request.request_id, status=0, message="",
                                                 exception_type="", payload=request.payload))


def replier(domain, space):
    server = Replier(DomainParticipant(domain), space)
    say("ready")
    while True:
        server.serve()


def digest_of(data):
    """The key of a description on urs/interface: SHA-256 of the bytes, in lower-case hex."""
    return hashlib.sha256(bytes(data)).hexdigest()


def offer(domain, space, service, descriptor_file, lease_ms):
    participant = DomainParticipant(domain)
    server = Replier(participant, space)
    with open(descriptor_file, "rb") as f:
        descriptor_set = list(f.read())
    # The catalog's QoS, and the liveliness the bridges' readers ask for: manual by topic, with a
    # lease no longer than theirs.
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
              Policy.History.KeepLast(1), Policy.Liveliness.ManualByTopic(duration(milliseconds=lease_ms)))
    descriptions = DataWriter(participant, Topic(participant, "urs/interface", InterfaceDescription), qos=qos)
    entries = DataWriter(participant, Topic(participant, "urs/catalog", ServiceEntry), qos=qos)
    description = InterfaceDescription(digest=digest_of(descriptor_set), descriptor_set=descriptor_set)
    entry = ServiceEntry(space=space, name=service, interface_name="URS.Diagnostic",
                         repository_id="IDL:URS/Diagnostic:1.0", origin="cyclone", bridge="cyclone",
                         deadline_ms=5000, interface_digest=description.digest)
    say("ready")
    while True:
        descriptions.write(description)
        entries.write(entry)
        server.serve()


def catalog(domain):
    participant = DomainParticipant(domain)
    matched = [0]

    class Matches(Listener):
        def on_subscription_matched(self, reader, status):
            if status.current_count != matched[0]:
                matched[0] = status.current_count
                say("matched", status.current_count)

    entries = DataReader(participant, Topic(participant, "urs/catalog", ServiceEntry), qos=CATALOG_QOS,
                         listener=Matches())
    while True:
        for entry in entries.take_iter(timeout=duration(seconds=1)):
            if entry.sample_info.valid_data:
                say("entry", f"{entry.space}/{entry.name}")


if __name__ == "__main__":
    command, domain = sys.argv[1], int(sys.argv[2])
    if command == "replier":
        replier(domain, sys.argv[3])
    elif command == "catalog":
        catalog(domain)
    elif command == "offer":
        offer(domain, sys.argv[3], sys.argv[4], sys.argv[5], int(sys.argv[6]))
    else:
        sys.exit(f"unknown command {command}")
