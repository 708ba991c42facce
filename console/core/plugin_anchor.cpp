// Part of the vilma_console_plugins OBJECT library so that it exists before any plugin does;
// plugins themselves live in console/plugins/<family>/.
namespace vilma::console {
void PluginAnchor() {}
}  // namespace vilma::console
