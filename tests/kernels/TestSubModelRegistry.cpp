// Consistency of the sub-model registry with docs/contact-models.md and the test files it cites.
#define BOOST_TEST_MODULE kernels_sub_model_registry
#include <boost/test/unit_test.hpp>

#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "kernels/SubModelRegistry.hpp"

using namespace railcosim::kernels;

namespace {
std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}
} // namespace

BOOST_AUTO_TEST_CASE(every_row_is_complete_and_keywords_are_unique) {
  std::set<std::string> keywords;
  for (const SubModelInfo& row : subModelRegistry) {
    BOOST_TEST_CONTEXT("keyword " << row.keyword) {
      BOOST_TEST(keywords.insert(row.keyword).second);
      for (const char* field : {row.kernel, row.parameters, row.history, row.reference, row.verifiedBy}) {
        BOOST_TEST(std::strlen(field) > 0u);
      }
    }
  }
  // Every kind the issue asks for has at least one sub-model.
  for (const SubModelKind kind : {SubModelKind::Normal, SubModelKind::Damping, SubModelKind::Tangential,
                                  SubModelKind::FrictionCoefficient, SubModelKind::Rolling, SubModelKind::TimeStep}) {
    bool present = false;
    for (const SubModelInfo& row : subModelRegistry) present = present || row.kind == kind;
    BOOST_TEST(present, "no sub-model of kind " << toString(kind));
  }
}

BOOST_AUTO_TEST_CASE(docs_and_tests_name_every_row) {
  const std::string docs = readFile(RAILCOSIM_CONTACT_MODELS_DOC);
  BOOST_REQUIRE_MESSAGE(!docs.empty(), "cannot read " << RAILCOSIM_CONTACT_MODELS_DOC);
  for (const SubModelInfo& row : subModelRegistry) {
    BOOST_TEST_CONTEXT("keyword " << row.keyword) {
      BOOST_TEST(docs.find(std::string("`") + row.keyword + "`") != std::string::npos);
      BOOST_TEST(docs.find(row.verifiedBy) != std::string::npos);
      BOOST_TEST(!readFile(std::string(RAILCOSIM_KERNEL_TESTS_DIR) + "/" + row.verifiedBy).empty());
    }
  }
}
