// dba-covariance: see dbacov/app/covariance_app.h and `dba-covariance --help`.
#include <exception>
#include <iostream>

#include "dbacov/app/covariance_app.h"

int main(int argc, char** argv) {
  try {
    return dbacov::app::runCovarianceApp(argc, argv, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "dba-covariance: internal error: " << e.what() << '\n';
    return 1;
  }
}
