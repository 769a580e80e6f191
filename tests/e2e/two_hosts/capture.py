#!/usr/bin/env python3
"""Captures every frame on one network interface (an AF_PACKET socket: needs root) and appends
it, raw, to a file until killed. The e2e tests grep the file for a marker sent in a call: found
on a plain link, absent on an encrypted one. The interface is put in promiscuous mode while the
capture runs, so that on a bridge (a compose network's) the frames it forwards between its ports
are captured too.
    capture.py INTERFACE OUT_FILE READY_FILE"""
import signal
import socket
import struct
import sys

ETH_P_ALL = 0x0003
SOL_PACKET = 263
PACKET_ADD_MEMBERSHIP = 1
PACKET_MR_PROMISC = 1


def main() -> int:
    interface, out_path, ready_path = sys.argv[1:4]
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    sock.bind((interface, 0))
    # struct packet_mreq: ifindex, type, address length, address; undone when the socket closes.
    membership = struct.pack("iHH8s", socket.if_nametoindex(interface), PACKET_MR_PROMISC, 0, b"")
    sock.setsockopt(SOL_PACKET, PACKET_ADD_MEMBERSHIP, membership)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    with open(out_path, "ab", buffering=0) as out:
        open(ready_path, "w").close()
        while True:
            out.write(sock.recv(65535))


if __name__ == "__main__":
    sys.exit(main())
