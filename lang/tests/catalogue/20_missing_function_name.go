// A declaration that cannot be read is reported once; the declarations
// after it are still read and checked.
package NoName

var Drone1 Quadcopter

func () {
	Drone1.Arm()
	Drone1.Land()
}

func INIT() {
	Drone1.Takeof(1)
}
