"""A DDS domain id no other test, benchmark or lab run holds: the same locks as
tests/support/dds_domain.cpp and deploy/lab.sh (one flock per id in /tmp/urs-dds-domains)."""
import fcntl
import os

FIRST, LAST = 10, 230
FOLDER = "/tmp/urs-dds-domains"


def lock_dds_domain():
    """Returns (domain, handle); the domain is held while the handle stays open."""
    os.makedirs(FOLDER, exist_ok=True)
    try:
        os.chmod(FOLDER, 0o1777)  # shared by every user's tests
    except OSError:
        pass
    span = LAST - FIRST + 1
    start = os.getpid() % span
    for step in range(span):
        domain = FIRST + (start + step) % span
        handle = open("%s/%d" % (FOLDER, domain), "a")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return domain, handle
        except OSError:
            handle.close()
    raise RuntimeError("no free DDS domain in %d..%d (locks in %s)" % (FIRST, LAST, FOLDER))
