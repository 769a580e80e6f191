# Code generation for URSLink's schemas.
#
# urs_proto_library(<target> PROTOS <file.proto>... [IMPORT_DIRS <dir>...] [LINK <target>...])
#   Compiles .proto files with protoc into one static library <target> (alias urs::<target>).
#   Also writes, next to the generated C++:
#     <target>.desc   a FileDescriptorSet with every file and its imports (run-time descriptions)
#     python/         Python modules (for clients written in Python)
#   The library's include directory is the generated folder, so code includes "<name>.pb.h".

find_program(URS_PROTOC NAMES protoc)
if(NOT URS_PROTOC)
  message(FATAL_ERROR "protoc not found: run deploy/install-deps.sh (Debian package protobuf-compiler)")
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
  add_library(${target} STATIC ${srcs} ${hdrs})
  add_library(urs::${target} ALIAS ${target})
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON
                        URS_DESCRIPTOR_SET ${desc} URS_PYTHON_DIR ${py_dir})
  target_include_directories(${target} PUBLIC ${out_dir})
  target_link_libraries(${target} PUBLIC protobuf::libprotobuf ${ARG_LINK})
  target_compile_options(${target} PRIVATE -w)
endfunction()
