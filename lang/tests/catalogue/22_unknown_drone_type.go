// A drone type that no capability profile names.
package UnknownType

var Drone1 Quadcoptr
var Drone2 Zeppelin

func INIT() {
	Drone1.Arm()
	Drone2.Arm()
}
