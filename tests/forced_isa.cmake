# The deformer's tests once more under each forced instruction set (MLSDEFORM_ISA). The kernel tests
# (test_stages, test_stages_ring, test_batch_fit, test_batch_accuracy, test_deformer_simd, test_rotation_rank1, and test_arap's
# local-step case) loop over every ISA the CPU runs themselves; these run the best one only by default. An ISA the CPU lacks is refused by the library
# ("this CPU cannot run it"): the test then reports itself skipped. Release build only (label no_sanitizer):
# under the sanitizers the segment tests alone take minutes per ISA.
if(MLSDEFORM_SANITIZE)
  return()
endif()
foreach(isa scalar ${MLSDEFORM_ISAS})  # the target architecture's (kernels/CMakeLists.txt)
  foreach(name test_deformer test_deformer_session test_deformer_segments test_deformer_continuity
               test_deformer_on_the_fly test_deformer_errors test_no_allocation test_arap test_rbf_centroids
               test_rbf_centroids_motion test_deformer_region test_handle_groups test_scale_invariance)
    if(NOT TARGET ${name})  # a cross build's chosen set (tests/CMakeLists.txt) may leave it out
      continue()
    endif()
    add_test(NAME isa_${isa}:${name} COMMAND ${name})
    set(_labels isa no_sanitizer)
    if(CMAKE_CROSSCOMPILING AND name STREQUAL "test_deformer")  # CI's ARM64 stage (tests/CMakeLists.txt)
      list(APPEND _labels cross)
    endif()
    set_tests_properties(isa_${isa}:${name} PROPERTIES ENVIRONMENT MLSDEFORM_ISA=${isa}
                         SKIP_REGULAR_EXPRESSION "this CPU cannot run it" LABELS "${_labels}" TIMEOUT 600)
  endforeach()
endforeach()
