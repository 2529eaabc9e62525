// dba-evaluate: see dbacov/app/evaluate_app.h and `dba-evaluate --help`.
#include <exception>
#include <iostream>

#include "dbacov/app/evaluate_app.h"
#include "dbacov/flow/opencv_flow.h"

int main(int argc, char** argv) {
  try {
    dbacov::flow::registerOpenCvFlow();  // --flow dis|farneback (OpenCV)
    return dbacov::app::runEvaluateApp(argc, argv, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "dba-evaluate: internal error: " << e.what() << '\n';
    return 1;
  }
}
