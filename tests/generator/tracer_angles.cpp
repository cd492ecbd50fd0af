// The tracer add_eom_model() would build, written by hand: the generator tests compile its output.
#include "angles_model.hpp"
#include <eomgen/tracer.hpp>
int main(int argc, char** argv) { return eom::gen::tracer_main<eomtest::AnglesModel>(argc, argv); }
