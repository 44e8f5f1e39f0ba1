# PCL's own CMake package pulls in VTK and MPI; the project needs only a few of its libraries, so
# they are found directly and wrapped in one imported target, terrain::pcl.
if(NOT TARGET terrain::pcl)
  find_path(TERRAIN_PCL_INCLUDE_DIR pcl/io/pcd_io.h PATH_SUFFIXES pcl-1.13 pcl-1.12 REQUIRED)
  find_package(Boost REQUIRED)
  add_library(terrain::pcl INTERFACE IMPORTED)
  set_target_properties(terrain::pcl PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${TERRAIN_PCL_INCLUDE_DIR}")
  target_include_directories(terrain::pcl SYSTEM INTERFACE ${TERRAIN_PCL_INCLUDE_DIR} ${Boost_INCLUDE_DIRS})
  foreach(lib segmentation sample_consensus filters search kdtree io common)
    find_library(TERRAIN_PCL_${lib}_LIBRARY pcl_${lib} REQUIRED)
    target_link_libraries(terrain::pcl INTERFACE ${TERRAIN_PCL_${lib}_LIBRARY})
  endforeach()
endif()
