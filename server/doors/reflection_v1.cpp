#include "doors/reflection_v1.h"

#include <algorithm>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include <unordered_set>

namespace dembuf::server {

namespace pb = google::protobuf;
namespace rv1 = grpc::reflection::v1;

namespace {

/// Adds `file` and, after it, every file it depends on, each once: a client needs them all to
/// build the types. `sent` is per answer, so every answer stands alone.
void AddFileAndDependencies(const pb::FileDescriptor* file, std::unordered_set<std::string>& sent,
                            rv1::FileDescriptorResponse* answer) {
  if (!sent.insert(file->name()).second) return;
  pb::FileDescriptorProto proto;
  file->CopyTo(&proto);
  answer->add_file_descriptor_proto(proto.SerializeAsString());
  for (int i = 0; i < file->dependency_count(); ++i)
    AddFileAndDependencies(file->dependency(i), sent, answer);
}

void SetError(rv1::ServerReflectionResponse* response, grpc::StatusCode code,
              const std::string& message) {
  auto* error = response->mutable_error_response();
  error->set_error_code(code);
  error->set_error_message(message);
}

void AnswerWithFile(const pb::FileDescriptor* file, const std::string& not_found,
                    rv1::ServerReflectionResponse* response) {
  if (!file) return SetError(response, grpc::StatusCode::NOT_FOUND, not_found);
  std::unordered_set<std::string> sent;
  AddFileAndDependencies(file, sent, response->mutable_file_descriptor_response());
}

}  // namespace

ReflectionV1Service::ReflectionV1Service(std::vector<std::string> services, int max_streams,
                                         const AccessPolicy* policy)
    : m_services(std::move(services)),
      m_streams(std::max(1, max_streams / 4), max_streams, "reflection streams", "a fixed limit"),
      m_policy(policy) {}

rv1::ServerReflectionResponse ReflectionV1Service::Answer(
    const rv1::ServerReflectionRequest& request) const {
  const pb::DescriptorPool* pool = pb::DescriptorPool::generated_pool();
  rv1::ServerReflectionResponse response;
  response.set_valid_host(request.host());
  *response.mutable_original_request() = request;
  switch (request.message_request_case()) {
    case rv1::ServerReflectionRequest::kFileByFilename: {
      const std::string& name = request.file_by_filename();
      AnswerWithFile(pool->FindFileByName(name), "no file " + name, &response);
      break;
    }
    case rv1::ServerReflectionRequest::kFileContainingSymbol: {
      const std::string& symbol = request.file_containing_symbol();
      AnswerWithFile(pool->FindFileContainingSymbol(symbol), "no symbol " + symbol, &response);
      break;
    }
    case rv1::ServerReflectionRequest::kFileContainingExtension: {
      const auto& wanted = request.file_containing_extension();
      const pb::Descriptor* type = pool->FindMessageTypeByName(wanted.containing_type());
      const pb::FieldDescriptor* extension =
          type ? pool->FindExtensionByNumber(type, wanted.extension_number()) : nullptr;
      AnswerWithFile(extension ? extension->file() : nullptr,
                     "no extension " + std::to_string(wanted.extension_number()) + " of " +
                         wanted.containing_type(),
                     &response);
      break;
    }
    case rv1::ServerReflectionRequest::kAllExtensionNumbersOfType: {
      const std::string& name = request.all_extension_numbers_of_type();
      const pb::Descriptor* type = pool->FindMessageTypeByName(name);
      if (!type) {
        SetError(&response, grpc::StatusCode::NOT_FOUND, "no message type " + name);
        break;
      }
      std::vector<const pb::FieldDescriptor*> extensions;
      pool->FindAllExtensions(type, &extensions);
      auto* numbers = response.mutable_all_extension_numbers_response();
      numbers->set_base_type_name(type->full_name());
      for (const pb::FieldDescriptor* extension : extensions)
        numbers->add_extension_number(extension->number());
      break;
    }
    case rv1::ServerReflectionRequest::kListServices:
      for (const std::string& name : m_services)
        response.mutable_list_services_response()->add_service()->set_name(name);
      break;
    case rv1::ServerReflectionRequest::MESSAGE_REQUEST_NOT_SET:
      SetError(&response, grpc::StatusCode::INVALID_ARGUMENT,
               "the request asks nothing: set one of file_by_filename, file_containing_symbol, "
               "file_containing_extension, all_extension_numbers_of_type, list_services");
      break;
  }
  return response;
}

grpc::Status ReflectionV1Service::ServerReflectionInfo(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<rv1::ServerReflectionResponse, rv1::ServerReflectionRequest>* stream) {
  Caller caller;
  if (m_policy) {
    try {
      const auto& metadata = context->client_metadata();
      const auto found = metadata.find("authorization");
      caller = m_policy->Identify(found == metadata.end()
                                      ? std::nullopt
                                      : std::optional<std::string>(std::string(
                                            found->second.data(), found->second.size())));
    } catch (const AccessDenied& e) {
      return {grpc::StatusCode::UNAUTHENTICATED, e.what()};
    }
  }
  std::string why;
  std::optional<StreamLimits::Place> place = m_streams.Take(caller, &why);
  if (!place) return {grpc::StatusCode::RESOURCE_EXHAUSTED, why};
  rv1::ServerReflectionRequest request;
  while (!context->IsCancelled() && stream->Read(&request)) {
    if (!stream->Write(Answer(request))) break;
  }
  return grpc::Status::OK;
}

}  // namespace dembuf::server
