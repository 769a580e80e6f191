"""Serving an IDL interface from Python: an Agent answers the operations of its Interface by
method name (docs/sdk.md)."""
import asyncio
import contextvars
import inspect
import logging

from google.protobuf import json_format

from ._proto import planet_pb2 as pl
from .errors import PlanetError, UserException

log = logging.getLogger("urslink")

_current = contextvars.ContextVar("urslink_current_call", default=None)


class CallInfo:
    """What an agent knows about the call it is answering: `service`, `operation`, `deadline_ms`
    (the effective deadline the server forwarded; 0 for a oneway), `oneway`, and `caller` and
    `caller_role`: the name and role ("client", "sam", "operator") the server authenticated for
    the calling session (Request.caller, which only the server sets; "" if it named none)."""

    def __init__(self, request):
        self.service = request.service
        self.operation = request.operation
        self.deadline_ms = request.deadline_ms
        self.oneway = request.oneway
        self.caller = request.caller.name
        roles = {1: "client", 2: "sam", 3: "operator"}
        self.caller_role = roles.get(request.caller.role, "") if self.caller else ""


def current_call():
    """The CallInfo of the call the running handler answers (None outside a handler)."""
    return _current.get()


class Agent:
    """Base class of a service agent. Give it an Interface (class attribute `interface`, or the
    constructor) and define one method per IDL operation, named like the operation:

        def setTarget(self, request):            # request: the operation's Request message
            ...                                   # return the Reply message, a dict of its fields,
                                                  # the value of its `result` field, or None
    Handlers may be coroutine functions. A plain function runs on the event loop and must not
    block, unless the class sets `blocking = True`: then plain handlers run in worker threads. Raise `self.interface.exception("Name",
    field=...)` for a declared IDL exception, PlanetError for a Planet status; any other exception
    answers INTERNAL. Attributes are operations too: `_get_x` / `_set_x`."""

    interface = None
    blocking = False    # True: plain (non-async) handlers run in worker threads (asyncio.to_thread)

    def __init__(self, interface=None):
        if interface is not None:
            self.interface = interface
        if self.interface is None:
            raise ValueError("%s has no interface: pass one, or set the class attribute" % type(self).__name__)
        self.client = None
        self.name = None
        missing = [op for op in self.interface.methods if not callable(getattr(self, op, None))]
        if missing:
            log.warning("urslink: %s does not implement %s of %s (calls get UNKNOWN_OPERATION)",
                        type(self).__name__, ", ".join(missing), self.interface.name)

    def _attach(self, client, name):
        self.client = client
        self.name = name

    async def publish(self, topic, payload=b"", content_type=""):
        """Publishes an event through the client serving this agent; returns its seq."""
        return await self.client.publish(topic, payload, content_type)

    async def _dispatch(self, request):
        """(status, message, payload, exception_type) of one Request."""
        label = "%s.%s" % (request.service, request.operation)
        method = self.interface.methods.get(request.operation)
        if method is None:
            return (pl.UNKNOWN_OPERATION, "interface %s has no operation '%s'" % (self.interface.name,
                                                                                 request.operation), b"", "")
        handler = getattr(self, request.operation, None)
        if not callable(handler):
            return (pl.UNKNOWN_OPERATION, "the agent of %s does not implement %s" % (request.service,
                                                                                 request.operation), b"", "")
        try:
            parsed = method.request.FromString(request.payload)
        except Exception:
            return (pl.BAD_ARGUMENTS, "payload of %s is not a valid %s" % (label, method.request.DESCRIPTOR.full_name),
                    b"", "")
        token = _current.set(CallInfo(request))
        try:
            if self.blocking and not inspect.iscoroutinefunction(handler):
                # contextvars are copied into the worker thread: current_call() works there too
                result = await asyncio.to_thread(handler, parsed)
            else:
                result = handler(parsed)
            if inspect.isawaitable(result):
                result = await result
            reply = _to_reply(method.reply, result)
            return (pl.OK, "", reply.SerializeToString(), "")
        except UserException as raised:
            return (pl.USER_EXCEPTION, raised.message, raised.payload, raised.type_name)
        except PlanetError as raised:
            return (raised.status, raised.message, b"", "")
        except Exception as error:
            log.exception("urslink: %s raised", label)
            return (pl.INTERNAL, "%s raised %s: %s" % (label, type(error).__name__, error), b"", "")
        finally:
            _current.reset(token)


def _to_reply(reply_type, result):
    if result is None:
        return reply_type()
    if isinstance(result, reply_type):
        return result
    if isinstance(result, dict):
        return json_format.ParseDict(result, reply_type())
    fields = reply_type.DESCRIPTOR.fields_by_name
    if "result" in fields:
        reply = reply_type()
        field = fields["result"]
        if field.message_type is not None:
            if isinstance(result, dict):
                json_format.ParseDict(result, reply.result)
            elif getattr(getattr(result, "DESCRIPTOR", None), "full_name", None) == field.message_type.full_name:
                reply.result.CopyFrom(result)
            else:
                raise TypeError("cannot make a %s of a %s: its result is a %s" % (
                    reply_type.DESCRIPTOR.full_name, type(result).__name__, field.message_type.full_name))
        elif field.label == field.LABEL_REPEATED:
            reply.result.extend(result)
        else:
            reply.result = result
        return reply
    raise TypeError("cannot make a %s of a %s: return the reply message, a dict of its fields or None"
                    % (reply_type.DESCRIPTOR.full_name, type(result).__name__))
