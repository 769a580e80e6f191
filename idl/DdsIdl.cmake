# Code generation for the types URSLink exchanges over DDS (Fast DDS).
#
# urs_dds_idl_library(<target> IDLS <file.idl>... [LINK <target>...])
#   Compiles DDS IDL files (IDL 4, e.g. @key annotations) with eProsima's fastddsgen into one
#   shared library <target> (alias urs::<target>) linking fastrtps and fastcdr. Per IDL file
#   <name>.idl, ${CMAKE_CURRENT_BINARY_DIR}/<target>/ receives <name>.h (the C++ types),
#   <name>PubSubTypes.h (the TopicDataType to register with a participant), <name>TypeObject.h (its
#   XTypes TypeObjects) and their .cxx files.
#   Code includes "<name>.h" / "<name>PubSubTypes.h"; the folder is a SYSTEM include directory so
#   strict warnings on the includer do not fire on generated code, which itself is compiled with -w.
#   - fastddsgen writes into an existing folder only (made first); IDL base names must be unique
#     within one library, and every output is regenerated when any listed IDL file changes.
#   - Its preprocessed IDL goes to a folder of its own per IDL file (-t): by default fastddsgen
#     writes /tmp/<name>.cc, which two builds of the same file at once (two build folders on one
#     machine) overwrite under each other, leaving a library without its PubSubTypes.
#   - Every type announces its XTypes TypeObject in discovery (PID_TYPE_OBJECT), so that other
#     parties' tools build the type at run time (docs/federation.md, Interoperability); the
#     generated code is corrected by DdsTypeObjects.cmake (unbounded strings, qualified names,
#     registration, no Fast DDS 2.9 TypeInformation), which refuses an IDL file with a string<255>.
#   - fastddsgen is a Java program (Debian package fastddsgen); fastrtps and fastcdr come from
#     libfastrtps-dev and libfastcdr-dev.

set(_URS_DDS_TYPE_OBJECTS_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/DdsTypeObjects.cmake)
find_program(URS_FASTDDSGEN NAMES fastddsgen DOC "fastddsgen, eProsima's DDS IDL compiler (Debian package fastddsgen)")
# At the top level so the imported targets are visible to every directory linking a DDS library.
find_package(fastcdr REQUIRED)
find_package(fastrtps REQUIRED)

function(urs_dds_idl_library target)
  cmake_parse_arguments(ARG "" "" "IDLS;LINK" ${ARGN})
  _urs_check_idl_arguments(urs_dds_idl_library ${target} "${ARG_UNPARSED_ARGUMENTS}" "${ARG_IDLS}"
                           URS_FASTDDSGEN fastddsgen)
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  _urs_resolve_idls(urs_dds_idl_library ${target} "${ARG_IDLS}" "" abs_idls names unused_includes)
  set(srcs)
  set(hdrs)
  foreach(abs IN LISTS abs_idls)
    get_filename_component(name ${abs} NAME_WE)
    set(outs ${out_dir}/${name}.h ${out_dir}/${name}.cxx
             ${out_dir}/${name}PubSubTypes.h ${out_dir}/${name}PubSubTypes.cxx
             ${out_dir}/${name}TypeObject.h ${out_dir}/${name}TypeObject.cxx)
    add_custom_command(
      OUTPUT ${outs}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir} ${out_dir}/${name}.tmp
      COMMAND ${URS_FASTDDSGEN} -replace -typeobject -d ${out_dir} -t ${out_dir}/${name}.tmp ${abs}
      COMMAND ${CMAKE_COMMAND} -DIDL=${abs} -DDIR=${out_dir} -DNAME=${name} -P ${_URS_DDS_TYPE_OBJECTS_SCRIPT}
      DEPENDS ${abs_idls} ${URS_FASTDDSGEN} ${_URS_DDS_TYPE_OBJECTS_SCRIPT}
      COMMENT "fastddsgen ${target}: ${name}.idl"
      VERBATIM)
    list(APPEND hdrs ${out_dir}/${name}.h ${out_dir}/${name}PubSubTypes.h ${out_dir}/${name}TypeObject.h)
    list(APPEND srcs ${out_dir}/${name}.cxx ${out_dir}/${name}PubSubTypes.cxx ${out_dir}/${name}TypeObject.cxx)
  endforeach()
  _urs_add_generated_library(${target} ${out_dir} URS_DDS_IDL_DIR "${srcs}" "${hdrs}"
                             fastrtps fastcdr ${ARG_LINK})
endfunction()
