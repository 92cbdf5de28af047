// The overload set for std::visit: a visitor made of lambdas, one for each alternative.
// Internal to the core.
#pragma once

namespace kiji::detail {

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

}  // namespace kiji::detail
