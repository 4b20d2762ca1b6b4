# Every third-party package is found here, once, from the Debian packages that
# deploy/install-deps.sh installs.
find_package(Threads REQUIRED)
find_package(OpenMP REQUIRED)
find_package(Eigen3 3.3 REQUIRED CONFIG)
find_package(nlohmann_json 3.10 REQUIRED CONFIG)
find_package(toml11 3.7 REQUIRED CONFIG)
find_package(CLI11 2.1 REQUIRED CONFIG)
if(DEMBUF_BUILD_TESTS)
  find_package(GTest REQUIRED CONFIG)
endif()
