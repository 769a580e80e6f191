"""URSLink's Python SDK: an asyncio Planet client and service agents for IDL interfaces.

    import urslink
    async with urslink.Client("127.0.0.1:7400", token_file="client.token") as client:
        diag = await client.proxy("diag")
        print((await diag.echo(text="hi")).result)

Reference: docs/sdk.md. Protocol: docs/planet.md."""
from ._proto import camus_pb2, planet_pb2
from .agent import Agent, CallInfo, current_call
from .client import CLIENT, OPERATOR, SAM, Client, ServiceProxy, Subscription, read_token_file, value_of
from .errors import PlanetError, UserException, status_name
from .interface import IdlError, Interface, Method, Types, compile_idl
from .wire import ProtocolError

__version__ = "0.1.0"

__all__ = ["Agent", "CallInfo", "current_call", "Client", "ServiceProxy", "Subscription", "read_token_file",
           "value_of", "PlanetError", "UserException", "status_name", "IdlError", "Interface", "Method", "Types",
           "compile_idl", "ProtocolError", "CLIENT", "SAM", "OPERATOR", "planet_pb2", "camus_pb2"]
