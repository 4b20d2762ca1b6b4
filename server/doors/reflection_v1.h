// gRPC server reflection v1, answered from the descriptors compiled into the daemon (protobuf's
// generated pool): grpcurl, Postman and other tools ask v1 first. Debian's gRPC 1.51 has no v1
// service, hence this one; its own v1alpha one is not served (a thread a stream, no cap).
#pragma once

#include <string>
#include <vector>

#include "access/access_policy.h"
#include "doors/stream_limits.h"
#include "grpc/reflection/v1/reflection.grpc.pb.h"

namespace dembuf::server {

class ReflectionV1Service final : public grpc::reflection::v1::ServerReflection::Service {
 public:
  /// `services`: the full names of the services the server offers, as list_services answers.
  /// `max_streams`: how many reflection streams may be open at once (each holds a thread).
  /// `policy`, when given, identifies the caller first, as every other call of the daemon:
  /// a caller it refuses takes no place (grpcurl sends a token with -H).
  ReflectionV1Service(std::vector<std::string> services, int max_streams,
                      const AccessPolicy* policy = nullptr);

  grpc::Status ServerReflectionInfo(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<grpc::reflection::v1::ServerReflectionResponse,
                               grpc::reflection::v1::ServerReflectionRequest>* stream) override;

  /// The answer to one question (public for the tests).
  grpc::reflection::v1::ServerReflectionResponse Answer(
      const grpc::reflection::v1::ServerReflectionRequest& request) const;

 private:
  std::vector<std::string> m_services;
  StreamLimits m_streams;
  const AccessPolicy* m_policy;
};

}  // namespace dembuf::server
