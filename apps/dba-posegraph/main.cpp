// dba-posegraph: see dbacov/app/posegraph_app.h and `dba-posegraph --help`.
#include <exception>
#include <iostream>
#include <new>

#include "dbacov/app/posegraph_app.h"

int main(int argc, char** argv) {
  try {
    return dbacov::app::runPoseGraphApp(argc, argv, std::cout, std::cerr);
  } catch (const std::bad_alloc&) {
    std::cerr
        << "dba-posegraph: out of memory: the inputs need more memory than this process may use\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "dba-posegraph: internal error: " << e.what() << '\n';
    return 1;
  }
}
