// dba-evaluate: see dbacov/app/evaluate_app.h and `dba-evaluate --help`.
#include <exception>
#include <iostream>
#include <new>

#include "dbacov/app/evaluate_app.h"
#include "dbacov/flow/opencv_flow.h"

int main(int argc, char** argv) {
  try {
    dbacov::flow::registerOpenCvFlow();  // --flow dis|farneback (OpenCV)
    return dbacov::app::runEvaluateApp(argc, argv, std::cout, std::cerr);
  } catch (const std::bad_alloc&) {
    std::cerr
        << "dba-evaluate: out of memory: the inputs need more memory than this process may use\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "dba-evaluate: internal error: " << e.what() << '\n';
    return 1;
  }
}
