"""The rules a JSON Schema must keep for Foxglove and Lichtblick to read a channel or a service of
the Foxglove WebSocket protocol: the stricter of the two readers (Lichtblick's and Foxglove's
parseChannel / parseJsonSchema, and the ws-protocol specification), as docs/dashboard.md ("Schema
rules") states them. A schema that breaks one hides its topic in Lichtblick ("Failed to parse
channel schema") or its service from the Service Call panel ("Failed to parse service").

    problems = channel_problems(channel)       # an advertised channel (a dict of the advertise message)
    problems = service_problems(service)       # an advertised service
    problems = schema_problems(text, where)    # a schema's JSON text

Each returns a list of strings, empty when every rule holds; each names the place that breaks one.
"""
import json

SCALARS = ("boolean", "number", "integer")


def _object(schema, where, out):
    """An object schema: "type": "object" and a "properties" object, every property a field."""
    if not isinstance(schema, dict):
        out.append("%s: a schema must be a JSON object" % where)
        return
    if schema.get("type") != "object":
        out.append('%s: "type" is %s, not "object"' % (where, json.dumps(schema.get("type"))))
    properties = schema.get("properties")
    if not isinstance(properties, dict):
        out.append('%s: no "properties" object (the readers list an object\'s fields from it)' % where)
        return
    for name, field in properties.items():
        _field(field, "%s.%s" % (where, name), out)


def _field(field, where, out):
    if not isinstance(field, dict):
        out.append("%s: a property's schema must be a JSON object" % where)
        return
    for keyword in ("$ref", "oneOf", "anyOf", "allOf"):
        if keyword in field:
            out.append("%s: %s (not followed by the readers: say the type itself)" % (where, keyword))
    kind = field.get("type")
    if kind in SCALARS:
        return
    if kind == "string":
        if field.get("contentEncoding") not in (None, "base64"):
            out.append("%s: contentEncoding %s (only base64 is read)" % (where, json.dumps(field["contentEncoding"])))
        return
    if kind == "object":
        _object(field, where, out)
        return
    if kind == "array":
        items = field.get("items")
        if not isinstance(items, dict):
            out.append('%s: an array without an "items" schema' % where)
            return
        item_kind = items.get("type")
        for keyword in ("$ref", "oneOf", "anyOf", "allOf"):
            if keyword in items:
                out.append("%s[]: %s (not followed by the readers)" % (where, keyword))
        if item_kind in SCALARS:
            return
        if item_kind == "string":
            if "contentEncoding" in items:
                out.append("%s[]: contentEncoding on an array item (refused by the readers)" % where)
            return
        if item_kind == "object":
            _object(items, where + "[]", out)
            return
        out.append("%s[]: item type %s (one of boolean, string, number, integer, object)" % (where, json.dumps(item_kind)))
        return
    if "type" not in field:
        out.append('%s: no "type" (one of boolean, string, number, integer, object, array)' % where)
    else:
        out.append("%s: type %s (one of boolean, string, number, integer, object, array)" % (where, json.dumps(kind)))


def schema_problems(text, where):
    try:
        schema = json.loads(text)
    except ValueError as e:
        return ["%s: the schema is not JSON: %s" % (where, e)]
    out = []
    _object(schema, where, out)
    return out


def _message(definition, where, out):
    if not isinstance(definition, dict):
        out.append("%s: missing (the readers need request and response)" % where)
        return
    if definition.get("encoding") != "json" or definition.get("schemaEncoding") != "jsonschema":
        out.append("%s: encoding %s / schemaEncoding %s (json / jsonschema expected)" %
                   (where, definition.get("encoding"), definition.get("schemaEncoding")))
    if not definition.get("schemaName"):
        out.append("%s: no schemaName" % where)
    out.extend(schema_problems(definition.get("schema", ""), "%s %s" % (where, definition.get("schemaName"))))


def channel_problems(channel):
    where = "channel %s" % channel.get("topic")
    out = []
    if channel.get("encoding") != "json" or channel.get("schemaEncoding", "jsonschema") != "jsonschema":
        out.append("%s: encoding %s / schemaEncoding %s" % (where, channel.get("encoding"), channel.get("schemaEncoding")))
    out.extend(schema_problems(channel.get("schema", ""), "%s (%s)" % (where, channel.get("schemaName"))))
    return out


def service_problems(service):
    where = "service %s" % service.get("name")
    out = []
    _message(service.get("request"), where + " request", out)
    _message(service.get("response"), where + " response", out)
    for deprecated in ("requestSchema", "responseSchema"):
        if deprecated in service:
            out.append("%s: sends the deprecated %s (a warning per service in the readers)" % (where, deprecated))
    return out
