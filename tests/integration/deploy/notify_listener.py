#!/usr/bin/python3
"""A service manager's end of sd_notify, for the systemd_units test: binds a Unix datagram socket at
SOCKET with SO_PASSCRED and appends "PID MESSAGE" to OUT for every datagram, PID being the sender's as
the kernel saw it (what systemd's NotifyAccess=main checks). Runs until killed.
    notify_listener.py SOCKET OUT
"""
import os
import socket
import struct
import sys

path, out = sys.argv[1], sys.argv[2]
if os.path.exists(path):
    os.unlink(path)
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_PASSCRED, 1)
s.bind(path)
with open(out, "a", buffering=1) as log:
    while True:
        data, ancillary, _, _ = s.recvmsg(4096, socket.CMSG_SPACE(struct.calcsize("3i")))
        pid = 0
        for level, kind, payload in ancillary:
            if level == socket.SOL_SOCKET and kind == socket.SCM_CREDENTIALS:
                pid = struct.unpack("3i", payload[:struct.calcsize("3i")])[0]
        for line in data.decode(errors="replace").splitlines():
            log.write(f"{pid} {line}\n")
