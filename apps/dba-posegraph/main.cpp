// dba-posegraph: see dbacov/app/posegraph_app.h and `dba-posegraph --help`.
#include <exception>
#include <iostream>

#include "dbacov/app/posegraph_app.h"

int main(int argc, char** argv) {
  try {
    return dbacov::app::runPoseGraphApp(argc, argv, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "dba-posegraph: internal error: " << e.what() << '\n';
    return 1;
  }
}
