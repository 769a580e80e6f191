# Corrects, in place, what `fastddsgen -typeobject` (2.3) generates for one IDL file, so that every
# DDS type of URSLink announces a true XTypes TypeObject that other vendors' tools can build a type
# from, without the TypeInformation that Cyclone DDS refuses. Run by urs_dds_idl_library (DdsIdl.cmake):
#
#   cmake -DIDL=<file.idl> -DDIR=<output folder> -DNAME=<base name of the IDL file> -P DdsTypeObjects.cmake
#
# What fastddsgen 2.3 gets wrong, and what is done about it:
# - An unbounded string is described as string<255> (it writes its own default bound): the bound
#   becomes 0, XTypes' "unbounded". A real string<255> cannot be told apart in its output, so an IDL
#   file declaring one is refused.
# - A struct's complete type object is named without its modules ("ServiceEntry"): it gets the
#   qualified name its TopicDataType registers ("urs::dds::ServiceEntry").
# - The type objects exist only once register<NAME>Types() ran, which its code calls in every
#   sample's constructor (a cost on every sample) and never before a type is registered with a
#   participant (so none was announced): each <Type>PubSubType constructor registers them instead,
#   and the samples no longer do.
# - Fast DDS 2.9 sends, besides the TypeObject (PID_TYPE_OBJECT), a TypeInformation
#   (PID_TYPE_INFORMATION) in its own pre-XTypes-1.3 layout; Cyclone DDS rejects it and ignores the
#   whole endpoint. Each PubSubType turns it off (auto_fill_type_information(false)).
# Each step fails the build, saying so, when the generated code no longer looks as expected.

foreach(var IDL DIR NAME)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "DdsTypeObjects.cmake: -D${var}=... is required")
  endif()
endforeach()

function(_urs_fail what)
  message(FATAL_ERROR "DdsTypeObjects.cmake (${IDL}): ${what}; the fastddsgen output changed: "
                      "review idl/DdsTypeObjects.cmake against it")
endfunction()

# Replaces every `from` in the variable `text` with `to`; fails, saying `what` is missing, if none.
function(_urs_replace text from to what)
  string(FIND "${${text}}" "${from}" at)
  if(at EQUAL -1)
    _urs_fail("${what}")
  endif()
  string(REPLACE "${from}" "${to}" replaced "${${text}}")
  set(${text} "${replaced}" PARENT_SCOPE)
endfunction()

file(READ ${IDL} idl_text)
if(idl_text MATCHES "string[ \t\r\n]*<[ \t\r\n]*255[ \t\r\n]*>")
  message(FATAL_ERROR "${IDL}: a string bounded to 255 cannot be told apart from an unbounded one in "
                      "fastddsgen 2.3's type objects; use another bound")
endif()

# The type objects: unbounded strings, qualified struct names.
set(type_object_file ${DIR}/${NAME}TypeObject.cxx)
set(pubsub_file ${DIR}/${NAME}PubSubTypes.cxx)
set(types_file ${DIR}/${NAME}.cxx)
file(READ ${type_object_file} type_objects)
file(READ ${pubsub_file} pubsub)
file(READ ${types_file} types)

string(REPLACE "get_string_identifier(255, " "get_string_identifier(0, " type_objects "${type_objects}")
string(REGEX MATCHALL "setName\\(\"[^\"]+\"\\)" registered "${pubsub}")  # no ';': a list
if(NOT registered)
  _urs_fail("no setName(\"...\") in ${pubsub_file}")
endif()
foreach(call IN LISTS registered)
  string(REGEX REPLACE "setName\\(\"([^\"]+)\"\\)" "\\1" qualified "${call}")
  string(REGEX REPLACE ".*::" "" short "${qualified}")
  _urs_replace(type_objects "header().detail().type_name(\"${short}\");"
               "header().detail().type_name(\"${qualified}\");"
               "no complete type object named ${short} in ${type_object_file}")
endforeach()

# Registration: once per type support rather than once per sample.
_urs_replace(types "    // Just to register all known types\n    register${NAME}Types();\n" ""
             "no register${NAME}Types() call in the constructors of ${types_file}")
set(header "#include \"${NAME}PubSubTypes.h\"\n")
_urs_replace(pubsub "${header}" "${header}#include \"${NAME}TypeObject.h\"\n"
             "${pubsub_file} does not include ${NAME}PubSubTypes.h")
set(added "\n            register${NAME}Types();  // the type objects, announced with the type")
string(APPEND added "\n            auto_fill_type_information(false);  // Fast DDS 2.9's layout: refused by others")
string(REGEX REPLACE "(setName\\(\"[^\"]+\"\\);)" "\\1${added}" pubsub "${pubsub}")

file(WRITE ${type_object_file} "${type_objects}")
file(WRITE ${pubsub_file} "${pubsub}")
file(WRITE ${types_file} "${types}")
