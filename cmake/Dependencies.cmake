# Every third-party package is found here, once, from the Debian packages that
# deploy/install-deps.sh installs.
find_package(Threads REQUIRED)
find_package(OpenMP REQUIRED)
find_package(Eigen3 3.3 REQUIRED CONFIG)
find_package(nlohmann_json 3.10 REQUIRED CONFIG)
find_package(toml11 3.7 REQUIRED CONFIG)
find_package(CLI11 2.1 REQUIRED CONFIG)
find_package(OpenSSL REQUIRED)  # SHA-256: results' provenance, API tokens, stored series
find_package(ZLIB REQUIRED)     # VTK files' compressed arrays (vtkZLibDataCompressor)
# The service: gRPC and Protobuf for the API, SQLite for the store, spdlog for logs.
if(DEMBUF_SERVICE)
  find_package(Protobuf 3.12 REQUIRED)
  find_package(gRPC 1.30 REQUIRED CONFIG)
  find_package(SQLite3 REQUIRED)
  find_package(spdlog 1.8 REQUIRED CONFIG)
  # The web pages' HTTP server (Debian's libcpp-httplib-dev, built with OpenSSL: HTTPS).
  find_package(PkgConfig REQUIRED)
  pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib>=0.11)
endif()
if(DEMBUF_BUILD_TESTS)
  find_package(GTest REQUIRED CONFIG)
endif()
