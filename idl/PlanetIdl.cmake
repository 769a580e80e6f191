# Code generation for URSLink's schemas.
#
# These functions are part of the installed package too: find_package(urslink) includes this file
# (installed in lib/cmake/urslink) after setting URS_IDL_DIR to the installed share/urslink/idl, so
# a project of its own turns its IDL into a library the same way (examples/cpp/minimal).
#
# urs_proto_library(<target> PROTOS <file.proto>... [IMPORT_DIRS <dir>...] [LINK <target>...])
#   Compiles .proto files with protoc into one shared library <target> (alias urs::<target>).
#   Also writes, next to the generated C++:
#     <target>.desc   a FileDescriptorSet with every file and its imports (run-time descriptions)
#     python/         Python modules (for clients written in Python)
#   The library's include directory is the generated folder, so code includes "<name>.pb.h";
#   property URS_GENERATED_HEADERS lists the headers (urs_install_library installs them).

find_program(URS_PROTOC NAMES protoc)
if(NOT URS_PROTOC)
  message(FATAL_ERROR "protoc not found: install the Debian package protobuf-compiler (deploy/install-deps.sh)")
endif()

function(urs_proto_library target)
  cmake_parse_arguments(ARG "" "" "PROTOS;IMPORT_DIRS;LINK" ${ARGN})
  if(NOT ARG_PROTOS)
    message(FATAL_ERROR "urs_proto_library(${target}): PROTOS is empty")
  endif()
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  set(py_dir ${out_dir}/python)
  set(desc ${out_dir}/${target}.desc)
  set(srcs)
  set(hdrs)
  set(import_args)
  set(abs_protos)
  foreach(dir IN LISTS ARG_IMPORT_DIRS)
    list(APPEND import_args -I${dir})
  endforeach()
  foreach(proto IN LISTS ARG_PROTOS)
    get_filename_component(abs ${proto} ABSOLUTE)
    get_filename_component(dir ${abs} DIRECTORY)
    get_filename_component(name ${abs} NAME_WE)
    list(APPEND import_args -I${dir})
    list(APPEND abs_protos ${abs})
    list(APPEND srcs ${out_dir}/${name}.pb.cc)
    list(APPEND hdrs ${out_dir}/${name}.pb.h)
  endforeach()
  list(REMOVE_DUPLICATES import_args)
  add_custom_command(
    OUTPUT ${srcs} ${hdrs} ${desc}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir} ${py_dir}
    COMMAND ${URS_PROTOC} ${import_args} --cpp_out=${out_dir} --python_out=${py_dir}
            --include_imports --descriptor_set_out=${desc} ${abs_protos}
    DEPENDS ${abs_protos} ${URS_PROTOC}
    COMMENT "protoc ${target}"
    VERBATIM)
  add_library(${target} SHARED ${srcs} ${hdrs})
  add_library(urs::${target} ALIAS ${target})
  set_target_properties(${target} PROPERTIES URS_DESCRIPTOR_SET ${desc} URS_PYTHON_DIR ${py_dir}
                        URS_GENERATED_HEADERS "${hdrs}")
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${out_dir}>)
  target_link_libraries(${target} PUBLIC protobuf::libprotobuf ${ARG_LINK})
  target_compile_options(${target} PRIVATE -w)
endfunction()

# _urs_resolve_idls(<caller> <target> <idls> <include_dirs> <out_abs> <out_names> <out_includes>)
#   Shared by the IDL functions: absolute IDL paths (each must exist), their base names (unique,
#   since each yields one output file of that name), and -I flags: the given INCLUDE_DIRS, then
#   the folder of every IDL file.
function(_urs_resolve_idls caller target idls include_dirs out_abs out_names out_includes)
  set(abs_idls)
  set(names)
  set(include_args)
  foreach(dir IN LISTS include_dirs)
    get_filename_component(abs_dir ${dir} ABSOLUTE)
    list(APPEND include_args -I${abs_dir})
  endforeach()
  foreach(idl IN LISTS idls)
    get_filename_component(abs ${idl} ABSOLUTE)
    get_filename_component(dir ${abs} DIRECTORY)
    get_filename_component(name ${abs} NAME_WE)
    if(NOT EXISTS ${abs})
      message(FATAL_ERROR "${caller}(${target}): IDL file '${abs}' does not exist")
    endif()
    if(name IN_LIST names)
      message(FATAL_ERROR "${caller}(${target}): two IDL files are named '${name}' (each yields "
                          "output files of that name); rename one or split the library")
    endif()
    list(APPEND names ${name})
    list(APPEND abs_idls ${abs})
    list(APPEND include_args -I${dir})
  endforeach()
  list(REMOVE_DUPLICATES include_args)
  set(${out_abs} ${abs_idls} PARENT_SCOPE)
  set(${out_names} ${names} PARENT_SCOPE)
  set(${out_includes} ${include_args} PARENT_SCOPE)
endfunction()

# _urs_check_idl_arguments(<caller> <target> <unparsed> <idls> <tool_var> <tool>)
#   Shared by the IDL functions: refuses unexpected arguments, an empty IDLS and a compiler not
#   found (<tool_var> names the find_program result; <tool> is the program and its Debian package).
function(_urs_check_idl_arguments caller target unparsed idls tool_var tool)
  if(NOT "${unparsed}" STREQUAL "")
    message(FATAL_ERROR "${caller}(${target}): unexpected arguments '${unparsed}'")
  endif()
  if("${idls}" STREQUAL "")
    message(FATAL_ERROR "${caller}(${target}): IDLS is empty")
  endif()
  if(NOT ${tool_var})
    message(FATAL_ERROR "${caller}(${target}): ${tool} not found: run deploy/install-deps.sh "
                        "(Debian package ${tool}) or set ${tool_var} to its path")
  endif()
endfunction()

# _urs_add_generated_library(<target> <out_dir> <dir_property> <srcs> <hdrs> [<link>...])
#   Shared by the IDL functions that compile generated C++ themselves: the shared library <target>
#   (alias urs::<target>) of <srcs> and <hdrs>, compiled with -w; <out_dir> is its SYSTEM include
#   directory and the value of property <dir_property>; URS_GENERATED_HEADERS lists <hdrs>; the
#   further arguments are linked PUBLIC.
function(_urs_add_generated_library target out_dir dir_property srcs hdrs)
  add_library(${target} SHARED ${srcs} ${hdrs})
  add_library(urs::${target} ALIAS ${target})
  set_target_properties(${target} PROPERTIES ${dir_property} ${out_dir} URS_GENERATED_HEADERS "${hdrs}")
  target_include_directories(${target} SYSTEM PUBLIC $<BUILD_INTERFACE:${out_dir}>)
  target_link_libraries(${target} PUBLIC ${ARGN})
  target_compile_options(${target} PRIVATE -w)
endfunction()

# urs_idl_library(<target> IDLS <file.idl>... [INCLUDE_DIRS <dir>...] [LINK <target>...])
#   Translates CORBA IDL files into the Planet schema with omniidl and the planet_proto back-end
#   (idl/omniidl_planet; rules in docs/idl-mapping.md), one <name>.proto per IDL file in
#   ${CMAKE_CURRENT_BINARY_DIR}/<target>_proto/, then compiles them with urs_proto_library into one
#   shared library <target> (alias urs::<target>): "<name>.pb.h" headers, the <target>.desc
#   FileDescriptorSet (property URS_DESCRIPTOR_SET) and Python modules (property URS_PYTHON_DIR).
#   - An IDL file #included by another must be listed too (each IDL file yields its own .proto,
#     imported by the includers); IDL base names must be unique within one library.
#   - The directory of every IDL file is on the include path; INCLUDE_DIRS adds more.
#   - urs_options.proto (the custom options every schema imports) is compiled once, in
#     urslink::idl_options, which the library links: never list it in PROTOS of another library.
#   - A refused IDL construct fails the build with "<file>:<line>: error: ..." from omniidl.

find_program(URS_OMNIIDL NAMES omniidl DOC "omniidl, the omniORB IDL compiler (Debian package omniidl)")
if(NOT URS_IDL_DIR)  # set by urslinkConfig.cmake in a project using the installed package
  set(URS_IDL_DIR ${CMAKE_CURRENT_LIST_DIR} CACHE INTERNAL "Folder of urs_options.proto")
endif()
set(URS_PLANET_BACKEND_DIR ${URS_IDL_DIR}/omniidl_planet CACHE INTERNAL
    "Folder of the omniidl planet_proto back-end")
set(URS_PLANET_BACKEND_FILES
    ${URS_PLANET_BACKEND_DIR}/planet_proto.py
    ${URS_PLANET_BACKEND_DIR}/planet_translator.py
    CACHE INTERNAL "Sources of the omniidl planet_proto back-end")

function(urs_idl_library target)
  cmake_parse_arguments(ARG "" "" "IDLS;INCLUDE_DIRS;LINK" ${ARGN})
  _urs_check_idl_arguments(urs_idl_library ${target} "${ARG_UNPARSED_ARGUMENTS}" "${ARG_IDLS}"
                           URS_OMNIIDL omniidl)
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target}_proto)
  _urs_resolve_idls(urs_idl_library ${target} "${ARG_IDLS}" "${ARG_INCLUDE_DIRS}" abs_idls names include_args)
  set(protos)
  foreach(name IN LISTS names)
    list(APPEND protos ${out_dir}/${name}.proto)
  endforeach()
  add_custom_command(
    OUTPUT ${protos}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
    COMMAND ${URS_OMNIIDL} -p ${URS_PLANET_BACKEND_DIR} -b planet_proto -C ${out_dir}
            ${include_args} ${abs_idls}
    DEPENDS ${abs_idls} ${URS_PLANET_BACKEND_FILES} ${URS_OMNIIDL}
    COMMENT "omniidl planet_proto ${target}"
    VERBATIM)
  urs_proto_library(${target} PROTOS ${protos} IMPORT_DIRS ${URS_IDL_DIR}
                    LINK urslink::idl_options ${ARG_LINK})
  # Python clients import urs_options_pb2 from the same folder as the generated modules.
  get_target_property(py_dir ${target} URS_PYTHON_DIR)
  add_custom_command(
    OUTPUT ${py_dir}/urs_options_pb2.py
    COMMAND ${CMAKE_COMMAND} -E make_directory ${py_dir}
    COMMAND ${URS_PROTOC} -I${URS_IDL_DIR} --python_out=${py_dir} ${URS_IDL_DIR}/urs_options.proto
    DEPENDS ${URS_IDL_DIR}/urs_options.proto ${URS_PROTOC}
    COMMENT "protoc urs_options.proto (Python) for ${target}"
    VERBATIM)
  target_sources(${target} PRIVATE ${py_dir}/urs_options_pb2.py)
  set_target_properties(${target} PROPERTIES URS_IDL_PROTO_DIR ${out_dir})
endfunction()

# urs_corba_idl_library(<target> IDLS <file.idl>... [NO_TYPECODES] [INCLUDE_DIRS <dir>...]
#                       [LINK <target>...])
#   Compiles CORBA IDL files with omniidl's C++ back-end (omniORB 4) into one shared library
#   <target> (alias urs::<target>) linking omniORB4 and omniDynamic4 (pkg-config).
#   Per IDL file <name>.idl, ${CMAKE_CURRENT_BINARY_DIR}/<target>/ receives <name>.hh (stubs and
#   skeletons), <name>SK.cc and <name>DynSK.cc (TypeCodes and Any operators: -Wba); with
#   NO_TYPECODES, only <name>.hh and <name>SK.cc (no _tc_<Type>, no Any operators: for a library
#   whose users call and serve through the stubs alone, it halves what is compiled). Code includes
#   "<name>.hh"; the folder is a SYSTEM include directory so strict warnings on the includer do
#   not fire on generated code, which itself is compiled with -w.
#   - omniidl's C++ back-end takes one file at a time: an IDL file #included by another must be
#     listed too (its stubs are emitted only for it); IDL base names must be unique.
#   - Every output is regenerated when any listed IDL file changes (includes are not tracked).
#   - The directory of every IDL file is on the include path; INCLUDE_DIRS adds more.
function(urs_corba_idl_library target)
  cmake_parse_arguments(ARG "NO_TYPECODES" "" "IDLS;INCLUDE_DIRS;LINK" ${ARGN})
  _urs_check_idl_arguments(urs_corba_idl_library ${target} "${ARG_UNPARSED_ARGUMENTS}" "${ARG_IDLS}"
                           URS_OMNIIDL omniidl)
  # GLOBAL: the imported target is linked from other directories (the library's users).
  if(NOT TARGET PkgConfig::OMNIORB)
    pkg_check_modules(OMNIORB REQUIRED IMPORTED_TARGET GLOBAL omniORB4 omniDynamic4)
  endif()
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  _urs_resolve_idls(urs_corba_idl_library ${target} "${ARG_IDLS}" "${ARG_INCLUDE_DIRS}" abs_idls names include_args)
  set(srcs)
  set(hdrs)
  set(any_args -Wba -Wbd=DynSK.cc)
  if(ARG_NO_TYPECODES)
    set(any_args)
  endif()
  foreach(abs IN LISTS abs_idls)
    get_filename_component(name ${abs} NAME_WE)
    set(outs ${out_dir}/${name}.hh ${out_dir}/${name}SK.cc)
    if(NOT ARG_NO_TYPECODES)
      list(APPEND outs ${out_dir}/${name}DynSK.cc)
    endif()
    add_custom_command(
      OUTPUT ${outs}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
      COMMAND ${URS_OMNIIDL} -bcxx ${any_args} -Wbh=.hh -Wbs=SK.cc -C ${out_dir} ${include_args} ${abs}
      DEPENDS ${abs_idls} ${URS_OMNIIDL}
      COMMENT "omniidl cxx ${target}: ${name}.idl"
      VERBATIM)
    list(APPEND hdrs ${out_dir}/${name}.hh)
    list(APPEND srcs ${out_dir}/${name}SK.cc)
    if(NOT ARG_NO_TYPECODES)
      list(APPEND srcs ${out_dir}/${name}DynSK.cc)
    endif()
  endforeach()
  _urs_add_generated_library(${target} ${out_dir} URS_CORBA_IDL_DIR "${srcs}" "${hdrs}"
                             PkgConfig::OMNIORB ${ARG_LINK})
endfunction()
