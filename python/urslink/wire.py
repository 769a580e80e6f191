"""Planet framing (docs/planet.md sections 1, 2 and 7): length prefixes, Chunk frames both ways,
limits checked before anything is allocated. Socket-free except read_frame()."""
import struct

from google.protobuf.message import DecodeError

from ._proto import planet_pb2 as pl

MIN_CHUNK_BYTES = 512
CHUNK_OVERHEAD = 64            # bytes of a Chunk frame's own fields (section 7)
MAX_MESSAGES_IN_PROGRESS = 16
_PREFIX = struct.Struct(">I")


class ProtocolError(Exception):
    """The peer broke the protocol; `status` is the Goodbye status to answer with."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status


def encode(frame, chunk_bytes, next_message_id):
    """The bytes of `frame` on the wire: one length-prefixed frame, or Chunk frames when its
    serialized size exceeds chunk_bytes. `next_message_id()` gives the id of a chunked message."""
    data = frame.SerializeToString()
    if len(data) <= chunk_bytes:
        return _PREFIX.pack(len(data)) + data
    message_id = next_message_id()
    piece = chunk_bytes - CHUNK_OVERHEAD
    out = bytearray()
    for offset in range(0, len(data), piece):
        chunk = pl.Frame()
        c = chunk.chunk
        c.message_id = message_id
        c.total_bytes = len(data)
        c.offset = offset
        c.data = data[offset:offset + piece]
        c.last = offset + piece >= len(data)
        body = chunk.SerializeToString()
        out += _PREFIX.pack(len(body)) + body
    return bytes(out)


def parse_frame(body):
    frame = pl.Frame()
    try:
        frame.ParseFromString(body)
    except DecodeError as error:
        raise ProtocolError(pl.BAD_ARGUMENTS, "frame of %d bytes does not parse as a Planet Frame: %s"
                            % (len(body), error)) from None
    if frame.WhichOneof("body") is None:
        raise ProtocolError(pl.BAD_ARGUMENTS, "frame of %d bytes has no body this version knows" % len(body))
    return frame


async def read_frame(reader, max_frame_bytes):
    """The next frame from an asyncio StreamReader; the length is checked before the body is read."""
    (length,) = _PREFIX.unpack(await reader.readexactly(4))
    if length == 0:
        raise ProtocolError(pl.BAD_ARGUMENTS, "frame of 0 bytes (a Frame always has a body)")
    if length > max_frame_bytes:
        raise ProtocolError(pl.PAYLOAD_TOO_LARGE,
                            "frame of %d bytes exceeds the limit of %d bytes (max_frame_bytes); the sender must "
                            "split larger messages into Chunk frames, or raise the receiver's chunk_bytes"
                            % (length, max_frame_bytes))
    return parse_frame(await reader.readexactly(length))


class Reassembler:
    """Joins Chunk frames into the Frame they carry, with the checks of section 7."""

    def __init__(self, max_message_bytes):
        self.max_message_bytes = max_message_bytes
        self.partial = {}   # message_id -> (total_bytes, bytearray)

    def feed(self, frame):
        """Returns the whole Frame when `frame` is not a Chunk or completes one, else None."""
        if frame.WhichOneof("body") != "chunk":
            return frame
        c = frame.chunk
        entry = self.partial.get(c.message_id)
        if entry is None:
            if c.offset != 0:
                raise ProtocolError(pl.BAD_ARGUMENTS, "chunk of message %d at offset %d: that message never started"
                                    % (c.message_id, c.offset))
            if c.total_bytes > self.max_message_bytes:
                raise ProtocolError(pl.PAYLOAD_TOO_LARGE, "message of %d bytes exceeds max_message_bytes %d"
                                    % (c.total_bytes, self.max_message_bytes))
            if len(self.partial) >= MAX_MESSAGES_IN_PROGRESS:
                raise ProtocolError(pl.BAD_ARGUMENTS, "more than %d chunked messages in progress"
                                    % MAX_MESSAGES_IN_PROGRESS)
            entry = (c.total_bytes, bytearray())
            self.partial[c.message_id] = entry
        total, data = entry
        if c.total_bytes != total or c.offset != len(data) or not c.data or len(data) + len(c.data) > total:
            raise ProtocolError(pl.BAD_ARGUMENTS, "chunk of message %d (offset %d, %d bytes, total %d) does not "
                                "continue the %d bytes received of %d" % (c.message_id, c.offset, len(c.data),
                                                                           c.total_bytes, len(data), total))
        data += c.data
        complete = len(data) == total
        if complete != c.last:
            raise ProtocolError(pl.BAD_ARGUMENTS, "chunk of message %d: 'last' is %s at %d of %d bytes"
                                % (c.message_id, c.last, len(data), total))
        if not complete:
            return None
        del self.partial[c.message_id]
        whole = parse_frame(bytes(data))
        if whole.WhichOneof("body") == "chunk":
            raise ProtocolError(pl.BAD_ARGUMENTS, "a chunked message holds a Chunk")
        return whole
