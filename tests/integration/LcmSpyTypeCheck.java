// Run by tests/integration/lcm_spy_test.cpp with Java's single-file source launcher, on the
// class path scripts/lcm-spy uses: looks up a type fingerprint (the first 8 bytes of an LCM
// message, given in hex) in lcm-spy's own type database (lcm.spy.LCMTypeDatabase, which scans
// the class path jars) and prints "FINGERPRINT <hex> -> <class name>" or "... -> none".
public class LcmSpyTypeCheck {
  public static void main(String[] args) {
    lcm.spy.LCMTypeDatabase database = new lcm.spy.LCMTypeDatabase();
    for (String hex : args) {
      long fingerprint = Long.parseUnsignedLong(hex, 16);
      Class<?> c = database.getClassByFingerprint(fingerprint);
      System.out.println("FINGERPRINT " + hex + " -> " + (c == null ? "none" : c.getName()));
    }
  }
}
