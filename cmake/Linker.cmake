# lld links where it is installed (issue 29; scripts/packages.txt installs it). The sanitizer
# pass links 28 programs of 50-90 MB each (ASan, line tables, whole unity batches of the
# static libraries): GNU ld took 1.3-2.1 s a link there, lld about half. GAUSS_LLD=OFF links
# with the compiler's default linker.
option(GAUSS_LLD "Link with lld when the compiler can use it" ON)
if(GAUSS_LLD)
  include(CheckLinkerFlag)
  check_linker_flag(CXX "-fuse-ld=lld" GAUSS_HAVE_LLD)
  if(GAUSS_HAVE_LLD)
    add_link_options(-fuse-ld=lld)
  endif()
endif()
