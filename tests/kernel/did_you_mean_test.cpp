// "Did you mean": the closest name by edit distance with adjacent transpositions, offered only
// when it is close enough to be a typo.
#include "cfuse/kernel/did_you_mean.h"

#include <catch2/catch.hpp>
#include <string>
#include <vector>

namespace cfuse {
namespace {

TEST_CASE("did you mean: one edit of each kind is a typo", "[kernel]") {
  const std::vector<std::string> keys = {"points", "label", "sigma", "camera"};
  CHECK(Suggest("lable", keys) == "label");   // adjacent transposition: one edit
  CHECK(Suggest("labels", keys) == "label");  // insertion
  CHECK(Suggest("lbel", keys) == "label");    // deletion
  CHECK(Suggest("sigmo", keys) == "sigma");   // substitution
  CHECK(Suggest("label", keys) == "label");   // itself
  CHECK(Suggest("zzzzz", keys).empty());
  CHECK(Suggest("label", {}).empty());
}

TEST_CASE("did you mean: the bound grows with the name's length", "[kernel]") {
  // Up to max(1, n / 3) edits for a name of n characters.
  CHECK(Suggest("xy", {"ab", "xb"}) == "xb");                       // n = 2: one edit
  CHECK(Suggest("xy", {"ab"}).empty());                             // two are too many
  CHECK(Suggest("cmaera", {"camera"}) == "camera");                 // n = 6: one transposition
  CHECK(Suggest("kamerz", {"camera"}) == "camera");                 // n = 6: two edits
  CHECK(Suggest("kqmerz", {"camera"}).empty());                     // three are too many
  CHECK(Suggest("distanse_to", {"distance_of"}) == "distance_of");  // n = 11: three
  // "ab" -> "ba" is one transposition, not two substitutions.
  CHECK(Suggest("ab", {"ba"}) == "ba");
}

TEST_CASE("did you mean: the closest wins, the first among equals", "[kernel]") {
  CHECK(Suggest("revolut", {"prismatic", "revolute", "revolve"}) == "revolute");
  CHECK(Suggest("cat", {"bat", "cab", "car"}) == "bat");
  CHECK(DidYouMean("lable", {"label"}) == " (did you mean 'label'?)");
  CHECK(DidYouMean("nothing", {"label"}).empty());
}

}  // namespace
}  // namespace cfuse
