// eom::mpi from a consumer: its header compiles and MPI links (nobody runs it: the build is the
// test).
#include <eom/ensemble/mpi_ensemble.hpp>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  MPI_Finalize();
  return 0;
}
