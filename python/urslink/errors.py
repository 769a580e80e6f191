"""Typed errors: every failed call raises PlanetError with the Planet status code and message."""
from ._proto import planet_pb2 as pl


def status_name(code):
    """The name of a Planet status number; UNKNOWN_STATUS for a number this version does not know."""
    try:
        return pl.Status.Name(code)
    except ValueError:
        return "UNKNOWN_STATUS"


class PlanetError(Exception):
    """A call, publish or subscription that did not succeed.

    `status` is the Planet status number, `code` its name (e.g. "DEADLINE_EXCEEDED"), `message`
    the reason given by whoever refused it."""

    def __init__(self, status, message=""):
        self.status = int(status)
        self.code = status_name(self.status)
        self.message = message
        super().__init__("%s: %s" % (self.code, message) if message else self.code)


class UserException(PlanetError):
    """An exception declared in the IDL (Planet status USER_EXCEPTION).

    `type_name` is the full Protobuf name of the exception (e.g. "URS.Failure"), `payload` its
    serialized message, `value` the decoded message when the interface is known (else None) and
    `fields` its fields as a dict (empty when not decoded). An agent raises one with
    `Interface.exception(name, **fields)`; it travels as in C++ and is raised again by the caller."""

    def __init__(self, type_name, payload=b"", message="", value=None):
        self.type_name = type_name
        self.payload = payload
        self.value = value
        text = message or type_name
        super().__init__(pl.USER_EXCEPTION, text)
        if message == "" and value is not None:
            self.message = "%s %s" % (type_name, _short(value))
            self.args = ("USER_EXCEPTION: " + self.message,)

    @property
    def fields(self):
        if self.value is None:
            return {}
        from google.protobuf import json_format
        return json_format.MessageToDict(self.value, preserving_proto_field_name=True,
                                         including_default_value_fields=True)


def _short(message):
    from google.protobuf import text_format
    return "{" + text_format.MessageToString(message, as_one_line=True) + "}"
