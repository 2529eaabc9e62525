// simul-dba: see dbacov/app/simul_app.h and `simul-dba --help`.
#include <exception>
#include <iostream>
#include <new>

#include "dbacov/app/simul_app.h"
#include "dbacov/flow/opencv_flow.h"

int main(int argc, char** argv) {
  try {
    dbacov::flow::registerOpenCvFlow();  // --flow dis|farneback (OpenCV)
    return dbacov::app::runSimulApp(argc, argv, std::cout, std::cerr);
  } catch (const std::bad_alloc&) {
    std::cerr
        << "simul-dba: out of memory: the inputs need more memory than this process may use\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "simul-dba: internal error: " << e.what() << '\n';
    return 1;
  }
}
