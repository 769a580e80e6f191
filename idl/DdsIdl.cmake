# Code generation for the types URSLink exchanges over DDS (Fast DDS).
#
# urs_dds_idl_library(<target> IDLS <file.idl>... [LINK <target>...])
#   Compiles DDS IDL files (IDL 4, e.g. @key annotations) with eProsima's fastddsgen into one
#   shared library <target> (alias urs::<target>) linking fastrtps and fastcdr. Per IDL file
#   <name>.idl, ${CMAKE_CURRENT_BINARY_DIR}/<target>/ receives <name>.h (the C++ types),
#   <name>PubSubTypes.h (the TopicDataType to register with a participant) and their .cxx files.
#   Code includes "<name>.h" / "<name>PubSubTypes.h"; the folder is a SYSTEM include directory so
#   strict warnings on the includer do not fire on generated code, which itself is compiled with -w.
#   - fastddsgen writes into an existing folder only (made first); IDL base names must be unique
#     within one library, and every output is regenerated when any listed IDL file changes.
#   - fastddsgen is a Java program (Debian package fastddsgen); fastrtps and fastcdr come from
#     libfastrtps-dev and libfastcdr-dev.

find_program(URS_FASTDDSGEN NAMES fastddsgen DOC "fastddsgen, eProsima's DDS IDL compiler (Debian package fastddsgen)")
# At the top level so the imported targets are visible to every directory linking a DDS library.
find_package(fastcdr REQUIRED)
find_package(fastrtps REQUIRED)

function(urs_dds_idl_library target)
  cmake_parse_arguments(ARG "" "" "IDLS;LINK" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "urs_dds_idl_library(${target}): unexpected arguments '${ARG_UNPARSED_ARGUMENTS}'")
  endif()
  if(NOT ARG_IDLS)
    message(FATAL_ERROR "urs_dds_idl_library(${target}): IDLS is empty")
  endif()
  if(NOT URS_FASTDDSGEN)
    message(FATAL_ERROR "urs_dds_idl_library(${target}): fastddsgen not found: run deploy/install-deps.sh "
                        "(Debian package fastddsgen) or set URS_FASTDDSGEN to its path")
  endif()
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  _urs_resolve_idls(urs_dds_idl_library ${target} "${ARG_IDLS}" "" abs_idls names unused_includes)
  set(srcs)
  set(hdrs)
  foreach(abs IN LISTS abs_idls)
    get_filename_component(name ${abs} NAME_WE)
    set(outs ${out_dir}/${name}.h ${out_dir}/${name}.cxx
             ${out_dir}/${name}PubSubTypes.h ${out_dir}/${name}PubSubTypes.cxx)
    add_custom_command(
      OUTPUT ${outs}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
      COMMAND ${URS_FASTDDSGEN} -replace -d ${out_dir} ${abs}
      DEPENDS ${abs_idls} ${URS_FASTDDSGEN}
      COMMENT "fastddsgen ${target}: ${name}.idl"
      VERBATIM)
    list(APPEND hdrs ${out_dir}/${name}.h ${out_dir}/${name}PubSubTypes.h)
    list(APPEND srcs ${out_dir}/${name}.cxx ${out_dir}/${name}PubSubTypes.cxx)
  endforeach()
  add_library(${target} SHARED ${srcs} ${hdrs})
  add_library(urs::${target} ALIAS ${target})
  set_target_properties(${target} PROPERTIES URS_DDS_IDL_DIR ${out_dir} URS_GENERATED_HEADERS "${hdrs}")
  target_include_directories(${target} SYSTEM PUBLIC $<BUILD_INTERFACE:${out_dir}>)
  target_link_libraries(${target} PUBLIC fastrtps fastcdr ${ARG_LINK})
  target_compile_options(${target} PRIVATE -w)
endfunction()
