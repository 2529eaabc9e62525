// simul-dba: see dbacov/app/simul_app.h and `simul-dba --help`.
#include <exception>
#include <iostream>

#include "dbacov/app/simul_app.h"
#include "dbacov/flow/opencv_flow.h"

int main(int argc, char** argv) {
  try {
    dbacov::flow::registerOpenCvFlow();  // --flow dis|farneback (OpenCV)
    return dbacov::app::runSimulApp(argc, argv, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "simul-dba: internal error: " << e.what() << '\n';
    return 1;
  }
}
