#include <google/protobuf/descriptor.pb.h>

#include <set>

#include "urs/schema/schema.hpp"

namespace urs::schema {

namespace gp = google::protobuf;

namespace {

void collect(const gp::FileDescriptor& file, std::set<std::string>& seen, gp::FileDescriptorSet& out) {
  if (!seen.insert(file.name()).second) return;
  for (int i = 0; i < file.dependency_count(); ++i) {
    // dependency() builds lazily-loaded imports (generated pool); nullptr only if that failed,
    // which cannot happen for a file that was itself built.
    if (const gp::FileDescriptor* dependency = file.dependency(i)) collect(*dependency, seen, out);
  }
  gp::FileDescriptorProto* proto = out.add_file();
  file.CopyTo(proto);
  file.CopyJsonNameTo(proto);
}

}  // namespace

std::string descriptor_set_for(const gp::FileDescriptor& file) {
  std::set<std::string> seen;
  gp::FileDescriptorSet set;
  collect(file, seen, set);
  return set.SerializeAsString();
}

}  // namespace urs::schema
