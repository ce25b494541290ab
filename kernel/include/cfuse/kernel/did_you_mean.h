// "Did you mean" for names in messages: the closest known name to a misspelt one.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace cfuse {

// The closest of `candidates` to `name` by edit distance (adjacent transpositions count as one
// edit, so "lable" is one from "label"), if close enough to be a typo; else "".
std::string Suggest(std::string_view name, const std::vector<std::string>& candidates);

// " (did you mean 'NAME'?)" for Suggest's answer, or "".
std::string DidYouMean(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace cfuse
